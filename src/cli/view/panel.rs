//! The viewer's egui panel: property, mode, slice count, transfer preset,
//! opacity scale, iso values, z-scale, standard views; the live legend,
//! the outline box and the frame figures (frame time, cut cells, adapter).

use anyhow::Result;
use egui::{Align2, Color32, vec2};
use glam::Vec3;

use stratasweep::gpu::render::Mode;
use stratasweep::gpu::render::options::mean_cell_size;
use stratasweep::gpu::render::transfer::COLORMAPS;
use stratasweep::gpu::view::scene::{FrameInfo, Scene};

use super::overlay::{LEGEND_SIZE, Legend, paint_legend, paint_outline};

/// What the panel asks the scene to change (applied after the frame).
#[derive(Clone, Debug)]
pub enum Action {
    /// Show another property.
    Property(String),
    /// Another mode.
    Mode(Mode),
    /// Another slice count.
    Slices(usize),
    /// Another colormap.
    Colormap(String),
    /// Opacity scale (multiplies the opacity per unit distance).
    Opacity(f64),
    /// Isovalues.
    Iso(Vec<f64>),
    /// Vertical exaggeration.
    ZScale(f64),
    /// Look along a direction with an up vector.
    View(Vec3, Vec3),
    /// The first camera again.
    Reset,
    /// Pre-integrated volume mode on or off.
    Preintegrated(bool),
    /// IJK clipping box (cell ranges `lo..hi`), or none.
    Clip(Option<[[usize; 2]; 3]>),
}

/// Panel state.
pub struct Panel {
    /// A line of status (errors, written files).
    pub status: String,
    /// The last frame's time, ms.
    pub frame_ms: f64,
    /// Draw fewer slices while the camera moves.
    pub motion_lod: bool,
    /// A change is pending (redraw).
    pub dirty: bool,
    properties: Vec<String>,
    iso_text: String,
    opacity: f64,
    user_unit: Option<f64>,
    slices: usize,
    z_scale: f64,
    adapter: String,
    /// Cells along I, J, K of an IJK grid (clipping), else none.
    cells: Option<[usize; 3]>,
    clip: [[usize; 2]; 3],
}

/// Every n-th slice drawn while the camera moves: 4 from 200 slices, 2 from 50.
pub fn motion_lod(slices: usize) -> u32 {
    match slices {
        200.. => 4,
        50.. => 2,
        _ => 1,
    }
}

impl Panel {
    /// The panel for `scene`'s options.
    pub fn new(scene: &Scene) -> Self {
        let g = scene.grid();
        let properties = g
            .point_data
            .iter()
            .chain(g.cell_data.iter())
            .map(|p| p.name.clone())
            .collect();
        Panel {
            status: String::new(),
            frame_ms: 0.0,
            motion_lod: true,
            dirty: false,
            properties,
            iso_text: scene
                .options
                .iso
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(", "),
            opacity: 1.0,
            user_unit: scene.options.unit_distance,
            slices: scene.options.slices,
            z_scale: scene.z_scale,
            adapter: scene.ctx().name.clone(),
            cells: match g.topology {
                stratasweep::grid::Topology::Structured { dims } => {
                    Some(dims.map(|d| d.saturating_sub(1)))
                }
                _ => None,
            },
            clip: match (scene.clip, &g.topology) {
                (Some(c), _) => c,
                (None, stratasweep::grid::Topology::Structured { dims }) => {
                    dims.map(|d| [0, d.saturating_sub(1)])
                }
                _ => [[0, 0]; 3],
            },
        }
    }

    /// Draws the outline, the legend and the controls; returns the changes asked for.
    pub fn ui(&mut self, ctx: &egui::Context, scene: &Scene, info: FrameInfo) -> Vec<Action> {
        let mut act = Vec::new();
        let screen = ctx.content_rect();
        let bg = ctx.layer_painter(egui::LayerId::background());
        let cam = &scene.camera;
        paint_outline(&bg, cam.display_view_proj(), cam.ext, screen.size());
        if let Ok(Some((t, range))) = scene.transfer() {
            let title = scene
                .property()
                .unwrap_or_else(|| "(slice position)".into());
            let r = Align2::RIGHT_BOTTOM.anchor_size(screen.max - vec2(10.0, 10.0), LEGEND_SIZE);
            paint_legend(
                &bg,
                r,
                &Legend {
                    title: &title,
                    range,
                    transfer: &t,
                },
            );
        }
        egui::Window::new("stratasweep")
            .default_pos([10.0, 10.0])
            .resizable(false)
            .show(ctx, |ui| self.controls(ui, scene, info, &mut act));
        self.dirty = !act.is_empty();
        act
    }

    fn controls(
        &mut self,
        ui: &mut egui::Ui,
        scene: &Scene,
        info: FrameInfo,
        act: &mut Vec<Action>,
    ) {
        ui.label(format!("adapter: {}", self.adapter));
        ui.label(format!(
            "frame {:.1} ms · {} cut cells · {} slices along {}{}",
            self.frame_ms,
            info.cut_cells,
            info.slices,
            ["x", "y", "z"][info.axis],
            if info.stale { " · building…" } else { "" }
        ));
        let s = &scene.stats;
        ui.label(format!(
            "re-sweeps {} (last {:.0} ms)",
            s.resweeps,
            s.resweep_ms.last().copied().unwrap_or(0.0)
        ));
        ui.separator();
        let current = scene.property().unwrap_or_default();
        egui::ComboBox::from_label("property")
            .selected_text(&current)
            .show_ui(ui, |ui| {
                for p in &self.properties {
                    if ui.selectable_label(*p == current, p).clicked() && *p != current {
                        act.push(Action::Property(p.clone()));
                    }
                }
            });
        ui.horizontal(|ui| {
            for (m, name) in [
                (Mode::Volume, "volume"),
                (Mode::Slices, "slices"),
                (Mode::Iso, "iso"),
            ] {
                if ui.selectable_label(scene.options.mode == m, name).clicked()
                    && scene.options.mode != m
                {
                    act.push(Action::Mode(m));
                }
            }
        });
        let slider = ui.add(
            egui::Slider::new(&mut self.slices, 10..=1000)
                .logarithmic(true)
                .text("slices"),
        );
        if slider.drag_stopped() || (slider.changed() && !slider.dragged()) {
            act.push(Action::Slices(self.slices));
        }
        egui::ComboBox::from_label("transfer")
            .selected_text(&scene.options.colormap)
            .show_ui(ui, |ui| {
                for c in COLORMAPS {
                    if ui
                        .selectable_label(scene.options.colormap == c, c)
                        .clicked()
                    {
                        act.push(Action::Colormap(c.to_string()));
                    }
                }
            });
        if ui
            .add(
                egui::Slider::new(&mut self.opacity, 0.05..=20.0)
                    .logarithmic(true)
                    .text("opacity ×"),
            )
            .changed()
        {
            act.push(Action::Opacity(self.opacity));
        }
        ui.horizontal(|ui| {
            ui.label("iso");
            let r = ui.text_edit_singleline(&mut self.iso_text);
            if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                let v: Vec<f64> = self
                    .iso_text
                    .split(',')
                    .filter_map(|x| x.trim().parse().ok())
                    .collect();
                if !v.is_empty() {
                    act.push(Action::Iso(v));
                }
            }
        });
        if ui
            .add(
                egui::Slider::new(&mut self.z_scale, 0.1..=200.0)
                    .logarithmic(true)
                    .text("z-scale"),
            )
            .changed()
        {
            act.push(Action::ZScale(self.z_scale));
        }
        ui.checkbox(&mut self.motion_lod, "fewer slices while moving");
        let mut pre = scene.preintegrated();
        if ui.checkbox(&mut pre, "pre-integrated (volume)").changed() {
            act.push(Action::Preintegrated(pre));
        }
        self.view_buttons(ui, act);
        if let Some(cells) = self.cells {
            self.clip_ui(ui, cells, act);
        }
        ui.label(
            "drag: orbit · right/Shift drag: pan · wheel: zoom · R reset · S screenshot · Q quit",
        );
        if !self.status.is_empty() {
            ui.colored_label(Color32::from_rgb(160, 40, 40), &self.status);
        }
    }

    fn view_buttons(&self, ui: &mut egui::Ui, act: &mut Vec<Action>) {
        ui.horizontal(|ui| {
            let up = Vec3::Z;
            for (name, d, u) in [
                ("top", -Vec3::Z, Vec3::Y),
                ("front", Vec3::Y, up),
                ("side", -Vec3::X, up),
                ("along I", Vec3::X, up),
                ("along J", Vec3::Y, up),
            ] {
                if ui.button(name).clicked() {
                    act.push(Action::View(d, u));
                }
            }
            if ui.button("reset").clicked() {
                act.push(Action::Reset);
            }
        });
    }

    fn clip_ui(&mut self, ui: &mut egui::Ui, cells: [usize; 3], act: &mut Vec<Action>) {
        let mut changed = false;
        ui.collapsing("IJK clip", |ui| {
            for (a, name) in ["I", "J", "K"].iter().enumerate() {
                ui.horizontal(|ui| {
                    ui.label(*name);
                    let [lo, hi] = &mut self.clip[a];
                    changed |= ui
                        .add(egui::DragValue::new(lo).range(0..=cells[a] - 1))
                        .changed();
                    changed |= ui
                        .add(egui::DragValue::new(hi).range(1..=cells[a]))
                        .changed();
                    if *hi <= *lo {
                        *hi = *lo + 1;
                    }
                });
            }
        });
        if changed {
            let full = (0..3).all(|a| self.clip[a] == [0, cells[a]]);
            act.push(Action::Clip((!full).then_some(self.clip)));
        }
    }

    /// The unit distance for the opacity scale: the user's (or the default
    /// for the current z-scale) divided by the scale.
    fn set_unit(&self, scene: &mut Scene) {
        scene.options.unit_distance = match (self.user_unit, self.opacity) {
            (None, 1.0) => None,
            (u, o) => {
                Some(u.unwrap_or_else(|| mean_cell_size(scene.grid()) * scene.z_scale.cbrt()) / o)
            }
        };
    }

    /// Applies one change to the scene (new slices build on the worker).
    pub fn apply(&mut self, a: Action, scene: &mut Scene) -> Result<()> {
        let o = &mut scene.options;
        match a {
            Action::Property(p) => o.property = Some(p),
            Action::Mode(m) => {
                if m == Mode::Iso && o.iso.is_empty() {
                    let r = scene.transfer()?.map_or((0.0, 1.0), |t| t.1);
                    scene.options.iso = vec![0.5 * (r.0 + r.1)];
                    self.iso_text = scene.options.iso[0].to_string();
                }
                scene.options.mode = m;
            }
            Action::Slices(n) => o.slices = n.max(1),
            Action::Colormap(c) => {
                o.colormap = c;
                o.transfer = None;
            }
            Action::Opacity(v) => {
                self.opacity = v;
                self.set_unit(scene);
            }
            Action::ZScale(z) => {
                scene.set_z_scale(z);
                self.set_unit(scene);
            }
            Action::Iso(v) => o.iso = v,
            Action::View(d, u) => scene.camera.look_along(d, u),
            Action::Reset => scene.reset_camera()?,
            Action::Preintegrated(on) => scene.set_preintegrated(on),
            Action::Clip(c) => scene.clip = c,
        }
        scene.request()?;
        Ok(())
    }
}
