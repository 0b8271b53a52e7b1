//! The GPU side of `slice` and `bench`: device choice and GPU emission.

use anyhow::{Context, Result};
use clap::ValueEnum;
use stratasweep::gpu::compute::slice::Emitter;
use stratasweep::gpu::compute::slice::slice_on;
use stratasweep::gpu::context::ContextOptions;
use stratasweep::gpu::context::GpuContext;
use stratasweep::grid::Grid;
use stratasweep::pipeline::SliceRequest;
use stratasweep::pipeline::SliceResult;
use stratasweep::policy::device::{Device, falls_back};
use stratasweep::structures::Structure;

/// `--device`: where polygons are generated.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub(crate) enum DeviceArg {
    /// The CPU sweep emits the polygons.
    Cpu,
    /// The CPU sweep finds the cut cells; the GPU emits (fails without an adapter).
    Gpu,
    /// The GPU when an adapter exists, else the CPU.
    Auto,
}

impl From<DeviceArg> for Device {
    fn from(d: DeviceArg) -> Self {
        match d {
            DeviceArg::Cpu => Device::Cpu,
            DeviceArg::Gpu => Device::Gpu,
            DeviceArg::Auto => Device::Auto,
        }
    }
}

/// The backends `WGPU_BACKEND` may name (a comma-separated list), with
/// the aliases wgpu itself accepts.
const BACKEND_NAMES: [(&[&str], wgpu::Backends); 4] = [
    (&["vulkan", "vk"], wgpu::Backends::VULKAN),
    (&["gl", "gles", "opengl"], wgpu::Backends::GL),
    (&["metal", "mtl"], wgpu::Backends::METAL),
    (&["dx12", "d3d12"], wgpu::Backends::DX12),
];

/// Parses a `WGPU_BACKEND` value: backend names separated by commas (any
/// case); `None` for an empty value. An unknown name is an error that
/// lists the valid ones (wgpu would skip it and then find no adapter).
pub(crate) fn parse_backends(value: &str) -> Result<Option<wgpu::Backends>> {
    if value.trim().is_empty() {
        return Ok(None);
    }
    let mut out = wgpu::Backends::empty();
    for name in value.split(',').map(str::trim) {
        let lower = name.to_lowercase();
        let Some((_, b)) = BACKEND_NAMES
            .iter()
            .find(|(names, _)| names.contains(&lower.as_str()))
        else {
            let valid: Vec<String> = BACKEND_NAMES
                .iter()
                .map(|(n, _)| format!("{} ({})", n[0], n[1..].join(", ")))
                .collect();
            anyhow::bail!(
                "WGPU_BACKEND='{value}': '{name}' is not a backend name; valid names: {} (several separated by commas; unset WGPU_BACKEND to let stratasweep choose)",
                valid.join(", ")
            );
        };
        out |= *b;
    }
    Ok(Some(out))
}

/// The device options of `--adapter`, with wgpu's own environment
/// variables: `WGPU_ADAPTER_NAME` when no `--adapter` is given, and
/// `WGPU_BACKEND` (for example `vulkan` or `gl`) for the backends, checked
/// by [`parse_backends`].
pub(crate) fn context_options(adapter: &Option<String>) -> Result<ContextOptions> {
    let from_env = || {
        std::env::var("WGPU_ADAPTER_NAME")
            .ok()
            .filter(|s| !s.is_empty())
    };
    let backends = match std::env::var("WGPU_BACKEND") {
        Ok(v) => parse_backends(&v)?,
        Err(std::env::VarError::NotPresent) => None,
        Err(std::env::VarError::NotUnicode(v)) => {
            anyhow::bail!("WGPU_BACKEND={v:?} is not UTF-8 text")
        }
    };
    Ok(ContextOptions {
        adapter: adapter.clone().or_else(from_env),
        backends,
        limits: None,
    })
}

/// When `WGPU_BACKEND` chose the backends: a note naming it, for errors of
/// the device it gave.
pub(crate) fn backend_chosen() -> Option<String> {
    let v = std::env::var("WGPU_BACKEND")
        .ok()
        .filter(|v| !v.trim().is_empty())?;
    Some(format!(
        "WGPU_BACKEND={v} chose the backend (unset it, or set WGPU_BACKEND=vulkan)"
    ))
}

/// Opens the GPU, printing the adapter's name unless quiet.
pub(crate) fn open(adapter: &Option<String>, quiet: bool) -> Result<GpuContext> {
    let ctx = GpuContext::new(&context_options(adapter)?)?;
    if !quiet {
        eprintln!("GPU adapter: {}", ctx.name);
    }
    Ok(ctx)
}

/// `slice --device` (as the policy chose it): `None` means "run the CPU
/// path" (cpu, or auto without an adapter).
pub(crate) fn slice_gpu(
    device: Device,
    adapter: &Option<String>,
    grid: &Grid,
    s: &Structure,
    req: &SliceRequest,
    quiet: bool,
) -> Result<Option<SliceResult>> {
    let ctx = match device {
        Device::Cpu => return Ok(None),
        Device::Gpu => {
            open(adapter, quiet).context("--device gpu (--device cpu slices on the CPU)")?
        }
        Device::Auto => match open(adapter, quiet) {
            Ok(c) => c,
            Err(e) if e.downcast_ref().is_some_and(|g| falls_back(device, g)) => {
                if !quiet {
                    eprintln!("--device auto: {e}\n  falling back to the CPU path");
                }
                return Ok(None);
            }
            Err(e) => return Err(e),
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

#[cfg(test)]
mod tests {
    use super::parse_backends;

    #[test]
    fn backend_names_parse_and_unknown_ones_are_named() {
        let b = wgpu::Backends::VULKAN | wgpu::Backends::GL;
        assert_eq!(parse_backends("Vulkan, gl").unwrap(), Some(b));
        assert_eq!(parse_backends(" ").unwrap(), None);
        let e = parse_backends("vulkan,foo").unwrap_err().to_string();
        assert!(
            e.contains("'foo' is not a backend name") && e.contains("gl (gles, opengl)"),
            "{e}"
        );
    }
}
