//! The viewer's scene without a window: the orbit camera, the slices of
//! the current (axis, count, property) cached on the GPU, and the worker
//! thread that sweeps and emits a new axis's slices while the previous ones
//! keep being drawn. The window (the CLI's `view`) and the orbit benchmark
//! drive it; tests drive it headless.
//!
//! A view change inside the axis's cone draws the cached slices: no sweep,
//! no compute dispatch. Crossing into another cone starts one build on a
//! worker; [`Scene::poll`] swaps the new slices in when they are ready.

use std::sync::Arc;
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::time::Instant;

use crate::grid::Grid;
use crate::structures::Structure;

use crate::gpu::context::GpuContext;
use crate::gpu::render::camera::{OrbitCamera, fit_camera, slicing_axis};
use crate::gpu::render::frame_setup::{DrawBindings, FrameSetup};
use crate::gpu::render::host_slices::build_slices;
use crate::gpu::render::iso_cache::{IsoLevels, build_levels};
use crate::gpu::render::options::{transfer_for, unit_distance};
use crate::gpu::render::renderer::OffscreenTarget;
use crate::gpu::render::slice_cache::{SliceKey, SliceSet, slice_key};
use crate::gpu::render::{Image, Mode, RenderError, RenderOptions, Renderer, Transfer};

/// What the worker builds: an axis's slices, or the missing isosurfaces.
enum Built {
    Set(SliceSet<'static>),
    Levels(Vec<(f64, SliceSet<'static>)>),
}

/// A build running on the worker.
struct Pending {
    key: SliceKey,
    rx: Receiver<Result<Built, RenderError>>,
    started: Instant,
    /// The worker (joined when the scene is dropped mid-build).
    worker: std::thread::JoinHandle<()>,
}

/// Counters of the scene's slice builds.
#[derive(Clone, Debug, Default)]
pub struct SceneStats {
    /// Builds finished after the first (axis, mode, count or property changes).
    pub resweeps: u32,
    /// Wall time of each of those builds, milliseconds.
    pub resweep_ms: Vec<f64>,
    /// The last build error, if any (the previous slices stay shown).
    pub last_error: Option<String>,
    /// Levels (slices or isovalues) swept by those builds.
    pub levels_swept: u64,
}

/// What a frame drew.
#[derive(Clone, Copy, Debug)]
pub struct FrameInfo {
    /// Cut cells of the drawn slices (of every drawn level).
    pub cut_cells: u64,
    /// Slicing axis of the drawn slices.
    pub axis: usize,
    /// Whether the drawn slices are not the wanted ones (a build is running).
    pub stale: bool,
    /// Slices drawn.
    pub slices: u32,
}

/// The viewer's scene: renderer, camera, cached slices, worker.
pub struct Scene {
    renderer: Renderer<'static>,
    grid: Arc<Grid>,
    structure: Arc<Structure>,
    /// Render options (property, mode, slices, transfer, background...).
    pub options: RenderOptions,
    /// Vertical exaggeration S.
    pub z_scale: f64,
    /// The camera.
    pub camera: OrbitCamera,
    bindings: DrawBindings,
    target: OffscreenTarget,
    /// Key and axis of the slices drawn now.
    shown: Option<SliceKey>,
    pending: Option<Pending>,
    /// Build counters.
    pub stats: SceneStats,
    /// IJK clipping box (cell index ranges `lo..hi`), IJK grids only.
    pub clip: Option<[[usize; 2]; 3]>,
    builds: u32,
    preintegrated: bool,
    /// Isosurfaces, one isovalue each.
    iso: IsoLevels,
}

impl Scene {
    /// A scene of `grid` showing `options` (its view direction, up and size
    /// give the first camera, exactly `render`'s); builds the first slices
    /// before returning, so the first frame equals `render`'s image.
    pub fn new(
        ctx: &'static GpuContext,
        grid: Arc<Grid>,
        structure: Arc<Structure>,
        options: RenderOptions,
        z_scale: f64,
        preintegrated: bool,
    ) -> Result<Self, RenderError> {
        if !(z_scale.is_finite() && z_scale > 0.0) {
            return Err(RenderError::Options(format!(
                "the z-scale {z_scale} must be positive"
            )));
        }
        let renderer = Renderer::new(ctx)?;
        let bindings = renderer.bindings();
        let target = renderer.target(options.size);
        let camera = fit_camera(&grid, &options, z_scale)?;
        let mut scene = Scene {
            renderer,
            grid,
            structure,
            options,
            z_scale,
            camera,
            bindings,
            target,
            shown: None,
            pending: None,
            stats: SceneStats::default(),
            clip: None,
            builds: 0,
            preintegrated,
            iso: IsoLevels::default(),
        };
        scene.request()?;
        scene.poll(true)?;
        if let Some(e) = scene.stats.last_error.take() {
            return Err(RenderError::Options(e));
        }
        Ok(scene)
    }

    /// The device.
    pub fn ctx(&self) -> &'static GpuContext {
        self.renderer.ctx()
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Compute dispatches issued so far (slice builds only).
    pub fn dispatches(&self) -> u64 {
        self.renderer.dispatches() + self.iso.dispatches()
    }

    /// Whether a build is running on the worker.
    pub fn building(&self) -> bool {
        self.pending.is_some()
    }

    /// The camera `render` would use for the current options.
    pub fn reset_camera(&mut self) -> Result<(), RenderError> {
        self.camera = fit_camera(&self.grid, &self.options, self.z_scale)?;
        Ok(())
    }

    /// Changes the vertical exaggeration, keeping the view direction.
    pub fn set_z_scale(&mut self, z_scale: f64) {
        if z_scale.is_finite() && z_scale > 0.0 {
            let f = (z_scale / self.z_scale) as f32;
            self.camera.ext.z *= f;
            self.camera.target.z *= f;
            self.camera.z_scale = z_scale as f32;
            self.z_scale = z_scale;
        }
    }

    /// Resizes the scene target (window resize).
    pub fn resize(&mut self, size: (u32, u32)) {
        let size = (size.0.max(1), size.1.max(1));
        if size != self.target.size {
            self.target = self.renderer.target(size);
            self.options.size = size;
            self.camera.aspect = size.0 as f32 / size.1 as f32;
        }
    }

    /// The slices the current camera and options want.
    pub fn wanted(&self) -> Result<SliceKey, RenderError> {
        let k = slice_key(&self.grid, &self.options, slicing_axis(self.camera.dir))?
            .with_clip(self.clip);
        Ok(if self.preintegrated && self.options.mode == Mode::Volume {
            k.with_attr_gradient()
        } else {
            k
        })
    }

    /// Pre-integrated volume mode on or off (new slices carry the
    /// attribute's gradient; they build on the worker).
    pub fn set_preintegrated(&mut self, on: bool) {
        self.preintegrated = on;
    }

    /// Whether volume mode is pre-integrated.
    pub fn preintegrated(&self) -> bool {
        self.preintegrated
    }

    /// Starts a build of the wanted slices on the worker when they are
    /// neither shown nor being built (one build at a time).
    pub fn request(&mut self) -> Result<(), RenderError> {
        let want = self.wanted()?;
        let have = self.shown.as_ref().is_some_and(|k| k.key == want.key);
        if have || self.pending.is_some() {
            return Ok(());
        }
        // Isosurfaces: only the isovalues not cached yet are swept.
        let missing = self.iso.missing(&want);
        if want.iso && missing.is_empty() {
            self.shown = Some(want);
            return Ok(());
        }
        let (tx, rx) = channel();
        let (ctx, grid, s, k) = (
            self.renderer.ctx(),
            self.grid.clone(),
            self.structure.clone(),
            want.clone(),
        );
        let worker = std::thread::Builder::new()
            .name("stratasweep-slices".into())
            .spawn(move || {
                let built = if k.iso {
                    build_levels(ctx, &grid, &s, &k, &missing).map(Built::Levels)
                } else {
                    build_slices(ctx, &grid, &s, &k).map(Built::Set)
                };
                let _ = tx.send(built);
            })
            .map_err(|e| RenderError::Options(format!("cannot start the slice worker: {e}")))?;
        self.pending = Some(Pending {
            key: want,
            rx,
            started: Instant::now(),
            worker,
        });
        Ok(())
    }

    /// Takes a finished build (waiting for it when `wait`), then starts the
    /// next one if the wanted slices changed meanwhile. Returns whether the
    /// shown slices changed.
    pub fn poll(&mut self, wait: bool) -> Result<bool, RenderError> {
        let mut changed = false;
        if let Some(p) = &self.pending {
            let got = if wait {
                p.rx.recv().ok()
            } else {
                match p.rx.try_recv() {
                    Ok(r) => Some(r),
                    Err(TryRecvError::Empty) => return Ok(false),
                    Err(TryRecvError::Disconnected) => None,
                }
            };
            let p = self.pending.take().expect("pending");
            let ms = p.started.elapsed().as_secs_f64() * 1e3;
            // It has sent (or stopped): it only has its captures to drop.
            let _ = p.worker.join();
            match got {
                Some(Ok(built)) => {
                    let levels = match built {
                        Built::Set(set) => {
                            let n = set.levels;
                            self.renderer.insert(&p.key.key, set);
                            n as u64
                        }
                        Built::Levels(l) => {
                            let n = l.len() as u64;
                            self.iso.insert(&p.key, l);
                            n
                        }
                    };
                    self.shown = Some(p.key);
                    if self.builds > 0 {
                        self.stats.resweeps += 1;
                        self.stats.resweep_ms.push(ms);
                        self.stats.levels_swept += levels;
                    }
                    self.builds += 1;
                    changed = true;
                }
                Some(Err(e)) => self.stats.last_error = Some(e.to_string()),
                None => self.stats.last_error = Some("the slice worker stopped".into()),
            }
        }
        if self.stats.last_error.is_none() {
            self.request()?;
        }
        Ok(changed)
    }

    /// The shown slices (one set per isovalue for isosurfaces).
    fn shown_sets(&self) -> Option<(&SliceKey, Vec<&SliceSet<'static>>)> {
        let k = self.shown.as_ref()?;
        if k.iso {
            return Some((k, self.iso.sets(k)?));
        }
        Some((k, vec![self.renderer.slices(&k.key)?]))
    }

    /// The value range and transfer function of the shown slices.
    pub fn transfer(&self) -> Result<Option<(Transfer, (f64, f64))>, RenderError> {
        match self.shown_sets() {
            Some((_, sets)) => {
                let range = sets[0].range;
                Ok(Some((transfer_for(&self.options, range)?, range)))
            }
            None => Ok(None),
        }
    }

    /// The property shown.
    pub fn property(&self) -> Option<String> {
        self.shown.as_ref().and_then(|k| k.property.clone())
    }

    /// Records the scene pass into the scene target (every `lod`-th slice).
    pub fn encode(
        &self,
        enc: &mut wgpu::CommandEncoder,
        lod: u32,
    ) -> Result<FrameInfo, RenderError> {
        let Some((k, sets)) = self.shown_sets().filter(|(_, s)| !s.is_empty()) else {
            return Err(RenderError::Options("no slices built".into()));
        };
        let set = sets[0];
        let transfer = transfer_for(&self.options, set.range)?;
        let (lut, vlo, vhi) = transfer.lut(set.range.0, set.range.1);
        let transfer = transfer.over(vlo, vhi);
        let mode = if k.iso { Mode::Iso } else { self.options.mode };
        let frame = FrameSetup {
            camera: self.camera,
            axis: k.axis,
            unit: unit_distance(&self.grid, &self.options, self.z_scale)?,
            mode,
            lod: lod.max(1),
            preintegrated: k.attr_gradient,
        };
        self.bindings.write(
            &self.renderer.ctx().queue,
            &frame.params(set, vlo, vhi),
            &transfer,
            &lut,
        );
        self.renderer
            .encode_sets(enc, &self.target, &sets, &self.bindings, &frame)?;
        let lod = if mode == Mode::Iso { 1 } else { lod.max(1) };
        let levels: u32 = sets.iter().map(|s| s.levels).sum();
        let cut: u64 = sets.iter().map(|s| s.cut_cells).sum();
        let slices = levels.div_ceil(lod);
        let stale = self.wanted().map_or(true, |w| w.key != k.key);
        Ok(FrameInfo {
            cut_cells: cut * slices as u64 / levels.max(1) as u64,
            axis: k.axis,
            stale,
            slices,
        })
    }

    /// The scene target (float, premultiplied).
    pub fn target(&self) -> &OffscreenTarget {
        &self.target
    }

    /// Reads the scene target back (the last frame drawn), over the background.
    pub fn read_target(&self) -> Result<Image, RenderError> {
        self.renderer
            .read_image(&self.target, self.options.background)
    }

    /// Draws a frame and reads it back, over the background (as `render`).
    pub fn image(&self, lod: u32) -> Result<Image, RenderError> {
        let ctx = self.renderer.ctx();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.encode(&mut enc, lod)?;
        ctx.queue.submit([enc.finish()]);
        self.renderer
            .read_image(&self.target, self.options.background)
    }
}

impl Drop for Scene {
    /// Waits for a build in flight: its worker uses the device, and one
    /// still running when the process exits can crash the driver (a
    /// segmentation fault after `view --orbit-bench` on NVIDIA's Vulkan
    /// driver).
    fn drop(&mut self) {
        if let Some(p) = self.pending.take() {
            let _ = p.worker.join();
        }
    }
}
