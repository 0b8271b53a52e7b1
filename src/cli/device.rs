//! The GPU side of `slice` and `bench`: device choice and GPU emission.

use anyhow::{Context, Result};
use clap::ValueEnum;
use stratasweep::gpu::context::ContextOptions;
use stratasweep::gpu::context::GpuContext;
use stratasweep::gpu::context::GpuError;
use stratasweep::gpu::slice::Emitter;
use stratasweep::gpu::slice::slice_on;
use stratasweep::grid::Grid;
use stratasweep::pipeline::SliceRequest;
use stratasweep::pipeline::SliceResult;
use stratasweep::structures::Structure;

/// Where polygons are generated.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub(crate) enum DeviceArg {
    /// The CPU sweep emits the polygons.
    Cpu,
    /// The CPU sweep finds the cut cells; the GPU emits (fails without an adapter).
    Gpu,
    /// The GPU when an adapter exists, else the CPU.
    Auto,
}

/// The device options of `--adapter`, with wgpu's own environment
/// variables: `WGPU_ADAPTER_NAME` when no `--adapter` is given, and
/// `WGPU_BACKEND` (for example `vulkan` or `gl`) for the backends.
pub(crate) fn context_options(adapter: &Option<String>) -> ContextOptions {
    let from_env = || {
        std::env::var("WGPU_ADAPTER_NAME")
            .ok()
            .filter(|s| !s.is_empty())
    };
    ContextOptions {
        adapter: adapter.clone().or_else(from_env),
        backends: wgpu::Backends::from_env(),
        limits: None,
    }
}

/// Opens the GPU, printing the adapter's name unless quiet.
pub(crate) fn open(adapter: &Option<String>, quiet: bool) -> Result<GpuContext, GpuError> {
    let ctx = GpuContext::new(&context_options(adapter))?;
    if !quiet {
        eprintln!("GPU adapter: {}", ctx.name);
    }
    Ok(ctx)
}

/// `slice --device`: `None` means "run the CPU path" (cpu, or auto without adapter).
pub(crate) fn slice_gpu(
    device: DeviceArg,
    adapter: &Option<String>,
    grid: &Grid,
    s: &Structure,
    req: &SliceRequest,
    quiet: bool,
) -> Result<Option<SliceResult>> {
    let ctx = match device {
        DeviceArg::Cpu => return Ok(None),
        DeviceArg::Gpu => {
            open(adapter, quiet).context("--device gpu (--device cpu slices on the CPU)")?
        }
        DeviceArg::Auto => match open(adapter, quiet) {
            Ok(c) => c,
            Err(e @ GpuError::NoAdapter { .. }) => {
                if !quiet {
                    eprintln!("--device auto: {e}\n  falling back to the CPU path");
                }
                return Ok(None);
            }
            Err(e) => return Err(e.into()),
        },
    };
    let (r, t) = slice_on(Emitter::Gpu(&ctx), grid, s, req)
        .context("the GPU path (--device cpu slices on the CPU)")?;
    if !quiet {
        eprintln!(
            "GPU emission: upload {:.2} ms, count+scan {:.2} ms, emit {:.2} ms ({} level chunk(s), {} grid part(s))",
            t.upload * 1e3,
            t.count * 1e3,
            t.emit * 1e3,
            t.chunks,
            t.grid_parts
        );
    }
    Ok(Some(r))
}
