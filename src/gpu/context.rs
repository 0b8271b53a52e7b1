//! The headless wgpu device: adapter choice (by name and backends, the
//! primary backends before GL), the adapter's real limits, errors instead
//! of panics.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use thiserror::Error;

/// Errors of the GPU path.
#[derive(Debug, Error)]
pub enum GpuError {
    /// No adapter at all (or none matching `--adapter`).
    #[error(
        "no GPU adapter{}{}: found [{}]. {}",
        .backends.as_ref().map(|b| format!(" on the backends {b}")).unwrap_or_default(),
        .wanted.as_ref().map(|w| format!(" matching '{w}'")).unwrap_or_default(),
        .available.join(", "),
        no_adapter_advice(.backends.as_deref())
    )]
    NoAdapter {
        /// The requested name, if any.
        wanted: Option<String>,
        /// Adapters that exist.
        available: Vec<String>,
        /// The backends searched, when chosen (`None`: the primary ones, then GL).
        backends: Option<String>,
    },
    /// The device could not be created.
    #[error("cannot open the device on adapter '{adapter}': {why}")]
    RequestDevice {
        /// Adapter name.
        adapter: String,
        /// wgpu's message.
        why: String,
    },
    /// A buffer would exceed a device limit.
    #[error(
        "{what} needs {bytes} bytes but the adapter '{adapter}' allows at most {limit} bytes per {kind}; use fewer slices, a smaller grid or the CPU path"
    )]
    TooLarge {
        /// Which buffer.
        what: String,
        /// Bytes needed.
        bytes: u64,
        /// The limit.
        limit: u64,
        /// Which limit (storage binding, buffer).
        kind: &'static str,
        /// Adapter name.
        adapter: String,
    },
    /// One frame's buffers exceed a limit: split the frame by levels
    /// (`gpu::compute::emit::emit_chunked` does).
    #[error(
        "{what} of one frame needs {bytes} bytes, over the limit of {limit} bytes per storage binding"
    )]
    FrameTooLarge {
        /// Which buffer.
        what: String,
        /// Bytes needed.
        bytes: u64,
        /// The limit.
        limit: u64,
    },
    /// The adapter lacks a capability this path needs.
    #[error("adapter '{adapter}' cannot run this: {why}")]
    Unsupported {
        /// Adapter name.
        adapter: String,
        /// What is missing.
        why: String,
    },
    /// The device ran out of memory while allocating a buffer.
    #[error(
        "the GPU '{adapter}' ran out of memory allocating {what}: {why}; use fewer slices, a smaller window or grid, or the CPU path"
    )]
    OutOfMemory {
        /// What was being allocated.
        what: String,
        /// wgpu's message.
        why: String,
        /// Adapter name.
        adapter: String,
    },
    /// A validation error, out-of-memory or device loss reported by wgpu.
    #[error("GPU error: {0}")]
    Device(String),
    /// The device did not finish in time.
    #[error("the GPU did not finish within {0:?} (device hung or lost)")]
    Timeout(Duration),
}

/// What to do when no adapter was found: install a Vulkan driver, or
/// (when the chosen backends leave Vulkan out) choose other backends.
fn no_adapter_advice(backends: Option<&str>) -> &'static str {
    match backends {
        Some(b) if !b.contains("vulkan") => {
            "Choose other backends (Vulkan finds Mesa's software rasteriser where there is no GPU), or slice on the CPU"
        }
        _ => {
            "Install a Vulkan driver; without a GPU, Mesa's software rasteriser works (Debian/Ubuntu: `apt install mesa-vulkan-drivers`), or slice on the CPU"
        }
    }
}

/// How long a wait on the device may take before it is an error.
pub const WAIT_LIMIT: Duration = Duration::from_secs(120);

/// A headless device and queue on one adapter.
pub struct GpuContext {
    /// The instance (windows create their surfaces from it).
    pub instance: wgpu::Instance,
    /// The adapter.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Adapter name and backend, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)`.
    pub name: String,
    /// The limits the device was opened with (the adapter's own).
    pub limits: wgpu::Limits,
    /// f64 in shaders: the face decider runs in f64 exactly like the CPU.
    pub shader_f64: bool,
    /// Rgba32Float targets can blend.
    pub float32_blend: bool,
    /// The first uncaptured error, if any (wgpu would panic otherwise).
    errors: Arc<Mutex<Option<String>>>,
}

/// Options for [`GpuContext::new`].
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Case-insensitive substring of the adapter name.
    pub adapter: Option<String>,
    /// Backends to look in. `None`: the primary ones (Vulkan, Metal,
    /// DX12), and GL only when they have no matching adapter. GL is not
    /// opened needlessly: its EGL display is never closed, and Mesa's
    /// threads behind it race the process exit (heap corruption at exit
    /// in about 1.5 % of runs on llvmpipe).
    pub backends: Option<wgpu::Backends>,
    /// Limits to use instead of the adapter's (tests lower them).
    pub limits: Option<wgpu::Limits>,
}

fn describe(a: &wgpu::Adapter) -> String {
    let i = a.get_info();
    format!("{} ({:?})", i.name, i.backend)
}

/// The best adapter of `backends` whose name contains `wanted` (real GPUs
/// first, then Vulkan), and the names of all the adapters seen.
fn pick_adapter(
    instance: &wgpu::Instance,
    backends: wgpu::Backends,
    wanted: Option<&str>,
) -> (Option<wgpu::Adapter>, Vec<String>) {
    let adapters = pollster::block_on(instance.enumerate_adapters(backends));
    let names: Vec<String> = adapters.iter().map(describe).collect();
    let mut cands: Vec<wgpu::Adapter> = adapters
        .into_iter()
        .filter(|a| wanted.is_none_or(|w| describe(a).to_lowercase().contains(&w.to_lowercase())))
        .collect();
    cands.sort_by_key(|a| {
        let i = a.get_info();
        let kind = match i.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other => 3,
            wgpu::DeviceType::Cpu => 4,
        };
        (kind, i.backend != wgpu::Backend::Vulkan)
    });
    (cands.into_iter().next(), names)
}

/// The adapters [`GpuContext::new`] chooses among with these `backends`
/// (`None`: the primary backends, or GL when they have none).
pub fn list_adapters(backends: Option<wgpu::Backends>) -> Vec<wgpu::AdapterInfo> {
    let tries = backends.map_or(vec![wgpu::Backends::PRIMARY, wgpu::Backends::GL], |b| {
        vec![b]
    });
    for b in tries {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: b,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let found = pollster::block_on(instance.enumerate_adapters(b));
        if !found.is_empty() {
            return found.iter().map(|a| a.get_info()).collect();
        }
    }
    Vec::new()
}

impl GpuContext {
    /// Opens a device on the adapters of `opts.backends` (filtered by
    /// `opts.adapter`); real GPUs come before software ones and Vulkan
    /// before the others.
    pub fn new(opts: &ContextOptions) -> Result<Self, GpuError> {
        Self::on_instance(
            |b| wgpu::InstanceDescriptor {
                backends: b,
                ..wgpu::InstanceDescriptor::new_without_display_handle()
            },
            opts,
        )
    }

    /// As [`GpuContext::new`], on an instance that knows the display of
    /// the windows it will present to (the viewer's); `display` is called
    /// once per instance tried.
    pub fn with_display(
        display: impl Fn() -> Box<dyn wgpu::wgt::WgpuHasDisplayHandle>,
        opts: &ContextOptions,
    ) -> Result<Self, GpuError> {
        Self::on_instance(
            |b| wgpu::InstanceDescriptor {
                backends: b,
                ..wgpu::InstanceDescriptor::new_with_display_handle(display())
            },
            opts,
        )
    }

    fn on_instance(
        desc: impl Fn(wgpu::Backends) -> wgpu::InstanceDescriptor,
        opts: &ContextOptions,
    ) -> Result<Self, GpuError> {
        let tries = opts
            .backends
            .map_or(vec![wgpu::Backends::PRIMARY, wgpu::Backends::GL], |b| {
                vec![b]
            });
        let mut available = Vec::new();
        for backends in tries {
            let instance = wgpu::Instance::new(desc(backends));
            let (adapter, names) = pick_adapter(&instance, backends, opts.adapter.as_deref());
            available.extend(names);
            if let Some(adapter) = adapter {
                return Self::open(instance, adapter, opts);
            }
        }
        Err(GpuError::NoAdapter {
            wanted: opts.adapter.clone(),
            available,
            backends: opts.backends.map(|b| {
                let names: Vec<String> = b.iter_names().map(|(n, _)| n.to_lowercase()).collect();
                names.join(", ")
            }),
        })
    }

    fn open(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
        opts: &ContextOptions,
    ) -> Result<Self, GpuError> {
        let name = describe(&adapter);
        let limits = opts.limits.clone().unwrap_or_else(|| adapter.limits());
        let feats = adapter.features();
        let shader_f64 = feats.contains(wgpu::Features::SHADER_F64);
        let float32_blend = feats.contains(wgpu::Features::FLOAT32_BLENDABLE);
        let mut required = wgpu::Features::empty();
        for f in [
            wgpu::Features::SHADER_F64,
            wgpu::Features::FLOAT32_BLENDABLE,
            wgpu::Features::INDIRECT_FIRST_INSTANCE,
            wgpu::Features::FLOAT32_FILTERABLE,
        ] {
            if feats.contains(f) {
                required |= f;
            }
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("stratasweep"),
            required_features: required,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::RequestDevice {
            adapter: name.clone(),
            why: e.to_string(),
        })?;
        let errors: Arc<Mutex<Option<String>>> = Arc::default();
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut g = sink.lock().unwrap_or_else(|p| p.into_inner());
            g.get_or_insert_with(|| e.to_string());
        }));
        let lost = errors.clone();
        device.set_device_lost_callback(move |reason, msg| {
            let mut g = lost.lock().unwrap_or_else(|p| p.into_inner());
            g.get_or_insert_with(|| format!("device lost ({reason:?}): {msg}"));
        });
        Ok(GpuContext {
            instance,
            adapter,
            device,
            queue,
            name,
            limits,
            shader_f64,
            float32_blend,
            errors,
        })
    }

    /// Whether the adapter is a software rasterizer (llvmpipe, WARP).
    pub fn is_software(&self) -> bool {
        self.adapter.get_info().device_type == wgpu::DeviceType::Cpu
    }

    /// Waits for all submitted work, then reports any uncaptured error.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: Some(WAIT_LIMIT),
            })
            .map_err(|e| match e {
                wgpu::PollError::Timeout => GpuError::Timeout(WAIT_LIMIT),
                e => GpuError::Device(e.to_string()),
            })?;
        self.check()
    }

    /// Returns (and clears) the first uncaptured error.
    pub fn check(&self) -> Result<(), GpuError> {
        let mut g = self.errors.lock().unwrap_or_else(|p| p.into_inner());
        match g.take() {
            Some(e) => Err(GpuError::Device(e)),
            None => Ok(()),
        }
    }

    /// Runs `make` (buffer creation) inside an out-of-memory error scope:
    /// an allocation the device cannot satisfy becomes
    /// [`GpuError::OutOfMemory`] naming `what`, and a device lost before
    /// or meanwhile its [`GpuError::Device`] message, never a panic.
    pub fn allocate<T>(&self, what: &str, make: impl FnOnce() -> T) -> Result<T, GpuError> {
        self.check()?;
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let out = make();
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::OutOfMemory {
                what: what.into(),
                why: e.to_string(),
                adapter: self.name.clone(),
            });
        }
        self.check().map_err(|e| match e {
            GpuError::Device(m) => GpuError::Device(format!("allocating {what}: {m}")),
            e => e,
        })?;
        Ok(out)
    }

    /// Checks that a storage buffer of `bytes` fits one binding and one buffer.
    pub fn check_storage(&self, what: &str, bytes: u64) -> Result<(), GpuError> {
        let bind = self.limits.max_storage_buffer_binding_size;
        let buf = self.limits.max_buffer_size;
        for (limit, kind) in [(bind, "storage binding"), (buf, "buffer")] {
            if bytes > limit {
                return Err(GpuError::TooLarge {
                    what: what.into(),
                    bytes,
                    limit,
                    kind,
                    adapter: self.name.clone(),
                });
            }
        }
        Ok(())
    }

    /// Reads back `len` bytes of `src` (which must have `COPY_SRC` usage).
    pub fn read_buffer(&self, src: &wgpu::Buffer, len: u64) -> Result<Vec<u8>, GpuError> {
        if len == 0 {
            return Ok(Vec::new());
        }
        let len4 = len.div_ceil(4) * 4;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: len4,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(src, 0, &staging, 0, len4);
        self.queue.submit([enc.finish()]);
        let slot: Arc<Mutex<Option<Result<(), wgpu::BufferAsyncError>>>> = Arc::default();
        let s2 = slot.clone();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            *s2.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
        });
        self.wait()?;
        // Another thread polling the same device may be running the callback.
        let start = std::time::Instant::now();
        loop {
            match slot.lock().unwrap_or_else(|p| p.into_inner()).take() {
                Some(Ok(())) => break,
                Some(Err(e)) => return Err(GpuError::Device(format!("map failed: {e}"))),
                None if start.elapsed() > WAIT_LIMIT => return Err(GpuError::Timeout(WAIT_LIMIT)),
                None => {}
            }
            std::thread::sleep(Duration::from_micros(200));
            self.wait()?;
        }
        let view = staging
            .get_mapped_range(..)
            .map_err(|e| GpuError::Device(format!("mapped range: {e}")))?;
        let out = view[..len as usize].to_vec();
        drop(view);
        staging.unmap();
        Ok(out)
    }
}
