//! The viewer's window: winit 0.30 event loop, a wgpu surface on the
//! scene's device, the scene drawn through the present pass, egui on top.
//! Mouse: orbit (left), pan (right or Shift+left), zoom (wheel). Keys: R
//! reset, S screenshot, Q/Escape quit, 1–6 standard views.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow};
use glam::Vec3;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use stratasweep::gpu::context::GpuContext;
use stratasweep::gpu::view::present::Compositor;
use stratasweep::gpu::view::scene::{FrameInfo, Scene};

use super::overlay::{Overlay, read_rgba8};
use super::panel::{Action, Panel, motion_lod};

/// What a scripted run does (`--frames`, `--screenshot`, `--orbit-bench`).
#[derive(Clone, Debug, Default)]
pub struct Script {
    /// Frames to draw before writing the screenshot and closing.
    pub frames: Option<u32>,
    /// Where the last frame goes.
    pub screenshot: Option<PathBuf>,
    /// Views of one full turn about the up axis.
    pub orbit: Option<u32>,
    /// Where the last frame goes as the window shows it (scene and panel).
    pub window_shot: Option<PathBuf>,
}

impl Script {
    fn active(&self) -> bool {
        self.frames.is_some() || self.orbit.is_some()
    }
    fn total(&self) -> Option<u32> {
        self.orbit.or(self.frames)
    }
}

/// Per-frame figures of a run.
#[derive(Clone, Debug, Default)]
pub struct Timeline {
    /// Wall time of each frame (draw, present, device idle), ms.
    pub frame_ms: Vec<f64>,
    /// Cut cells drawn per frame.
    pub cut_cells: Vec<u64>,
    /// Whether a frame drew stale slices (a build was running).
    pub stale: Vec<bool>,
}

/// What draws a frame's present pass, outline and panel into a target of
/// one format (the window's surface or the headless texture).
struct FrameParts {
    compositor: Compositor,
    overlay: Overlay,
}

impl FrameParts {
    fn new(ctx: &GpuContext, format: wgpu::TextureFormat) -> Result<Self> {
        Ok(FrameParts {
            compositor: Compositor::new(ctx, format)?,
            overlay: Overlay::new(ctx, format),
        })
    }
}

struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    parts: FrameParts,
    egui_winit: egui_winit::State,
}

#[derive(Default)]
struct Pointer {
    left: bool,
    right: bool,
    shift: bool,
    at: Option<(f64, f64)>,
    moved_at: Option<Instant>,
}

/// The application: scene, window, input, panel state, figures.
pub struct App {
    /// The scene.
    pub scene: Scene,
    script: Script,
    gfx: Option<Gfx>,
    pointer: Pointer,
    panel: Panel,
    /// Figures of the frames drawn.
    pub timeline: Timeline,
    frame: u32,
    /// The first error (the loop exits on it).
    pub error: Option<anyhow::Error>,
    last_info: Option<FrameInfo>,
    /// When the application was made (egui's clock when headless).
    started: Instant,
}

impl App {
    /// An application over `scene`.
    pub fn new(scene: Scene, script: Script) -> Self {
        let panel = Panel::new(&scene);
        App {
            scene,
            script,
            gfx: None,
            pointer: Pointer::default(),
            panel,
            timeline: Timeline::default(),
            frame: 0,
            error: None,
            last_info: None,
            started: Instant::now(),
        }
    }

    fn fail(&mut self, el: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        el.exit();
    }

    fn open_window(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let (w, h) = self.scene.options.size;
        let attrs = Window::default_attributes()
            .with_title("stratasweep view")
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = Arc::new(el.create_window(attrs).context("cannot open a window")?);
        let ctx = self.scene.ctx();
        let surface = ctx
            .instance
            .create_surface(window.clone())
            .context("cannot create a wgpu surface for the window")?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&ctx.adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| anyhow!("the adapter '{}' cannot present to this window", ctx.name))?;
        let caps = surface.get_capabilities(&ctx.adapter);
        // A non-sRGB format shows the same bytes as `render`'s PNG.
        if let Some(f) = caps.formats.iter().find(|f| !f.is_srgb()) {
            config.format = *f;
        }
        config.present_mode = wgpu::PresentMode::AutoNoVsync;
        surface.configure(&ctx.device, &config);
        let parts = FrameParts::new(ctx, config.format)?;
        let egui_winit = egui_winit::State::new(
            parts.overlay.egui.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(ctx.limits.max_texture_dimension_2d as usize),
        );
        self.scene.resize((size.width, size.height));
        self.gfx = Some(Gfx {
            window,
            surface,
            config,
            parts,
            egui_winit,
        });
        Ok(())
    }

    fn resized(&mut self, w: u32, h: u32) {
        let ctx = self.scene.ctx();
        if let Some(g) = &mut self.gfx
            && w > 0
            && h > 0
        {
            g.config.width = w;
            g.config.height = h;
            g.surface.configure(&ctx.device, &g.config);
            self.scene.resize((w, h));
        }
    }

    /// Steps a scripted orbit, takes a finished slice build and picks the
    /// level of detail: the start of every frame.
    fn begin_frame(&mut self) -> Result<u32> {
        if let (Some(n), true) = (self.script.orbit, self.frame > 0) {
            self.scene
                .camera
                .orbit(std::f32::consts::TAU / n as f32, 0.0);
        }
        self.scene.poll(false)?;
        if let Some(e) = self.scene.stats.last_error.take() {
            self.panel.status = format!("slice build failed: {e}");
        }
        let moving = !self.script.active()
            && self
                .pointer
                .moved_at
                .is_some_and(|t| t.elapsed() < Duration::from_millis(250));
        Ok(if moving && self.panel.motion_lod {
            motion_lod(self.scene.options.slices)
        } else {
            1
        })
    }

    /// Whether the frame being drawn is a scripted run's last.
    fn last_frame(&self) -> bool {
        self.script.total().is_some_and(|n| self.frame + 1 >= n)
    }

    /// Records the scene, the outline and the panel over `view` (`size`
    /// pixels) with `parts`, given egui's `input`.
    fn encode_frame(
        &mut self,
        parts: &mut FrameParts,
        enc: &mut wgpu::CommandEncoder,
        (view, size): (&wgpu::TextureView, (u32, u32)),
        input: egui::RawInput,
        lod: u32,
    ) -> Result<(FrameInfo, Vec<Action>, egui::PlatformOutput)> {
        let ctx = self.scene.ctx();
        let info = self.scene.encode(enc, lod)?;
        let target = self.scene.target();
        let background = self.scene.options.background;
        parts.compositor.encode(ctx, enc, target, view, background);
        parts
            .compositor
            .encode_outline(ctx, enc, target, view, &self.scene.camera);
        let panel = &mut self.panel;
        let scene = &self.scene;
        let mut actions = Vec::new();
        let out = parts.overlay.paint(ctx, enc, view, size, input, |ectx| {
            actions = panel.ui(ectx, scene, info);
        });
        Ok((info, actions, out))
    }

    /// After the frame's submission and the device's idle: applies the
    /// panel's actions and records the frame's figures. Returns whether
    /// the scripted run is over.
    fn end_frame(&mut self, t0: Instant, info: FrameInfo, actions: Vec<Action>) -> Result<bool> {
        for a in actions {
            self.panel.apply(a, &mut self.scene)?;
        }
        self.timeline
            .frame_ms
            .push(t0.elapsed().as_secs_f64() * 1e3);
        self.timeline.cut_cells.push(info.cut_cells);
        self.timeline.stale.push(info.stale);
        self.panel.frame_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.last_info = Some(info);
        self.frame += 1;
        Ok(self.script.total().is_some_and(|n| self.frame >= n))
    }

    /// Draws one frame; returns whether the scripted run is over.
    fn redraw(&mut self) -> Result<bool> {
        let t0 = Instant::now();
        let lod = self.begin_frame()?;
        let ctx = self.scene.ctx();
        let Some(mut g) = self.gfx.take() else {
            return Ok(false);
        };
        let r = self.redraw_window(&mut g, ctx, lod);
        self.gfx = Some(g);
        match r? {
            Some((info, actions)) => self.end_frame(t0, info, actions),
            None => Ok(false),
        }
    }

    /// The window's part of [`App::redraw`]: draws into the surface's
    /// texture (or a readable copy for the window screenshot) and presents.
    fn redraw_window(
        &mut self,
        g: &mut Gfx,
        ctx: &GpuContext,
        lod: u32,
    ) -> Result<Option<(FrameInfo, Vec<Action>)>> {
        let frame = match g.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                g.surface.configure(&ctx.device, &g.config);
                return Ok(None);
            }
            _ => return Ok(None),
        };
        let shot = match (&self.script.window_shot, self.last_frame()) {
            (Some(_), true) => Some(offscreen(
                ctx,
                (g.config.width, g.config.height),
                g.config.format,
            )),
            _ => None,
        };
        let view = match &shot {
            Some(t) => t.create_view(&Default::default()),
            None => frame.texture.create_view(&Default::default()),
        };
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let input = g.egui_winit.take_egui_input(&g.window);
        let size = (g.config.width, g.config.height);
        let (info, actions, out) =
            self.encode_frame(&mut g.parts, &mut enc, (&view, size), input, lod)?;
        g.egui_winit.handle_platform_output(&g.window, out);
        ctx.queue.submit([enc.finish()]);
        g.window.pre_present_notify();
        ctx.queue.present(frame);
        ctx.wait()?;
        if let (Some(t), Some(p)) = (&shot, &self.script.window_shot) {
            let rgba = read_rgba8(ctx, t)?;
            write_png(p, size, &rgba)?;
        }
        Ok(Some((info, actions)))
    }

    /// Draws the scripted frames without a window (`view --headless`): each
    /// as the window draws it (scene, outline, panel), into an offscreen
    /// texture of the window's size, with no present. Writes the
    /// screenshots the script names.
    pub fn run_headless(&mut self) -> Result<()> {
        if self.script.total().is_none() {
            return Err(anyhow!("--headless needs --frames or --orbit-bench"));
        }
        let ctx = self.scene.ctx();
        let size = self.scene.options.size;
        let format = wgpu::TextureFormat::Rgba8Unorm;
        let mut parts = FrameParts::new(ctx, format)?;
        let tex = offscreen(ctx, size, format);
        let view = tex.create_view(&Default::default());
        self.scene.resize(size);
        let screen =
            egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(size.0 as f32, size.1 as f32));
        loop {
            let t0 = Instant::now();
            let lod = self.begin_frame()?;
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            let input = egui::RawInput {
                screen_rect: Some(screen),
                time: Some(t0.duration_since(self.started).as_secs_f64()),
                ..Default::default()
            };
            let (info, actions, _) =
                self.encode_frame(&mut parts, &mut enc, (&view, size), input, lod)?;
            ctx.queue.submit([enc.finish()]);
            ctx.wait()?;
            if let (true, Some(p)) = (self.last_frame(), &self.script.window_shot) {
                write_png(p, size, &read_rgba8(ctx, &tex)?)?;
            }
            if self.end_frame(t0, info, actions)? {
                break;
            }
        }
        if let Some(p) = self.script.screenshot.clone() {
            self.screenshot(&p)?;
        }
        Ok(())
    }

    /// Writes the scene target (the last frame's scene, without the panel)
    /// as a PNG, composited over the background as `render` does.
    pub fn screenshot(&self, path: &PathBuf) -> Result<()> {
        let img = self.scene.read_target()?;
        let ctx = || format!("cannot write {}", path.display());
        stratasweep::io::atomic::write_bytes(path, &img.png().with_context(ctx)?).with_context(ctx)
    }

    fn key(&mut self, el: &ActiveEventLoop, key: &Key) -> Result<()> {
        let c = &mut self.scene.camera;
        let up = Vec3::Z;
        match key.as_ref() {
            Key::Named(NamedKey::Escape) | Key::Character("q") => el.exit(),
            Key::Character("r") => self.scene.reset_camera()?,
            Key::Character("s") => {
                let p = PathBuf::from(format!("stratasweep-{}.png", self.frame));
                self.screenshot(&p)?;
                self.panel.status = format!("wrote {}", p.display());
            }
            Key::Character("1") => c.look_along(-Vec3::Z, Vec3::Y),
            Key::Character("2") => c.look_along(Vec3::Z, Vec3::Y),
            Key::Character("3") => c.look_along(Vec3::Y, up),
            Key::Character("4") => c.look_along(-Vec3::Y, up),
            Key::Character("5") => c.look_along(-Vec3::X, up),
            Key::Character("6") => c.look_along(Vec3::X, up),
            _ => return Ok(()),
        }
        self.pointer.moved_at = Some(Instant::now());
        Ok(())
    }

    fn pointer_moved(&mut self, x: f64, y: f64) {
        let Some(g) = &self.gfx else { return };
        if let Some((px, py)) = self.pointer.at
            && (self.pointer.left || self.pointer.right)
        {
            let (w, h) = (g.config.width as f32, g.config.height as f32);
            let (dx, dy) = ((x - px) as f32 / w, (y - py) as f32 / h);
            let c = &mut self.scene.camera;
            if self.pointer.right || self.pointer.shift {
                c.pan(dx, -dy);
            } else {
                c.orbit(-dx * std::f32::consts::PI, -dy * std::f32::consts::PI);
            }
            self.pointer.moved_at = Some(Instant::now());
        }
        self.pointer.at = Some((x, y));
    }

    fn input(&mut self, el: &ActiveEventLoop, event: &WindowEvent) -> Result<()> {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(s) => self.resized(s.width, s.height),
            WindowEvent::ModifiersChanged(m) => self.pointer.shift = m.state().shift_key(),
            WindowEvent::MouseInput { state, button, .. } => {
                let down = *state == ElementState::Pressed;
                match button {
                    MouseButton::Left => self.pointer.left = down,
                    MouseButton::Right | MouseButton::Middle => self.pointer.right = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => self.pointer_moved(position.x, position.y),
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => *y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.scene.camera.zoom(1.1f32.powf(lines));
                self.pointer.moved_at = Some(Instant::now());
            }
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(el, &event.logical_key)?;
            }
            _ => return Ok(()),
        }
        if let Some(g) = &self.gfx {
            g.window.request_redraw();
        }
        Ok(())
    }
}

/// An 8-bit render target that can be read back (window screenshots and
/// headless frames).
fn offscreen(
    ctx: &GpuContext,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("offscreen frame"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// Writes straight RGBA bytes as a PNG, atomically (`io::atomic`): on
/// any failure the file at `path`, if any, stays as it was.
pub fn write_png(path: &PathBuf, size: (u32, u32), rgba: &[u8]) -> Result<()> {
    let ctx = || format!("cannot write {}", path.display());
    let mut png = Vec::new();
    let mut enc = png::Encoder::new(&mut png, size.0, size.1);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().with_context(ctx)?;
    w.write_image_data(rgba).with_context(ctx)?;
    w.finish().with_context(ctx)?;
    stratasweep::io::atomic::write_bytes(path, &png).with_context(ctx)
}

impl ApplicationHandler for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.gfx.is_none()
            && let Err(e) = self.open_window(el)
        {
            self.fail(el, e);
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if let WindowEvent::RedrawRequested = event {
            match self.redraw() {
                Ok(true) => {
                    if let Some(p) = self.script.screenshot.clone()
                        && let Err(e) = self.screenshot(&p)
                    {
                        self.fail(el, e);
                    }
                    el.exit();
                }
                Ok(false) => {}
                Err(e) => self.fail(el, e),
            }
            return;
        }
        let consumed = match &mut self.gfx {
            Some(g) => {
                let r = g.egui_winit.on_window_event(&g.window, &event);
                if r.repaint {
                    g.window.request_redraw();
                }
                r.consumed
            }
            None => false,
        };
        let always = matches!(
            event,
            WindowEvent::CloseRequested
                | WindowEvent::Resized(_)
                | WindowEvent::ModifiersChanged(_)
        );
        let release = matches!(
            event,
            WindowEvent::MouseInput {
                state: ElementState::Released,
                ..
            }
        );
        if (!consumed || always || release)
            && let Err(e) = self.input(el, &event)
        {
            self.fail(el, e);
        }
    }

    fn about_to_wait(&mut self, el: &ActiveEventLoop) {
        let Some(g) = &self.gfx else { return };
        let moving = self
            .pointer
            .moved_at
            .is_some_and(|t| t.elapsed() < Duration::from_millis(300));
        if self.script.active() || moving || self.scene.building() || self.panel.dirty {
            g.window.request_redraw();
            el.set_control_flow(ControlFlow::Poll);
        } else {
            el.set_control_flow(ControlFlow::WaitUntil(
                Instant::now() + Duration::from_millis(500),
            ));
        }
    }
}
