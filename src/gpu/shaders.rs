//! WGSL sources (one file per pass in `wgsl/`, shared code in
//! `wgsl/shared/`), their composition into modules, and naga validation.
//!
//! A compute module is the decider precision alias, the shared types, the
//! shared cell code and one pass ([`compute_source`]); a render module is
//! the shared types, the shared drawing code, for the pre-integrated
//! passes their shared code, and one pass ([`render_source`],
//! [`pre_source`]).

use crate::gpu::context::GpuError;

/// Structs and constants shared with Rust.
pub const TYPES: &str = include_str!("../../wgsl/shared/types.wgsl");
/// Bindings and per-cell logic of the compute passes.
pub const CELL: &str = include_str!("../../wgsl/shared/cell.wgsl");
/// Count pass.
pub const COUNT: &str = include_str!("../../wgsl/count.wgsl");
/// Scan pass.
pub const SCAN: &str = include_str!("../../wgsl/scan.wgsl");
/// Emit pass.
pub const EMIT: &str = include_str!("../../wgsl/emit.wgsl");
/// Span-space binning passes (GPU-only variant).
pub const BIN: &str = include_str!("../../wgsl/bin.wgsl");
/// Shared by the render passes: parameters, transfer LUT, vertex stages.
pub const DRAW: &str = include_str!("../../wgsl/shared/draw.wgsl");
/// Slices pass (volume, slices and iso modes).
pub const SLICES: &str = include_str!("../../wgsl/slices.wgsl");
/// Shared by the pre-integrated passes: table, scalar targets, segments.
pub const PRE: &str = include_str!("../../wgsl/shared/pre.wgsl");
/// Pre-integrated slab pass (one per slice, far to near).
pub const PRE_SLAB: &str = include_str!("../../wgsl/pre_slab.wgsl");
/// The outer surface's ray distances (before the slab passes).
pub const PRE_SURFACE: &str = include_str!("../../wgsl/pre_surface.wgsl");
/// The segment in front of the nearest slice (after the slab passes).
pub const PRE_FRONT: &str = include_str!("../../wgsl/pre_front.wgsl");
/// Present pass (the viewer's float target over the background).
pub const PRESENT: &str = include_str!("../../wgsl/present.wgsl");

/// The compute module of one pass: the decider precision alias (`f64`
/// when the adapter has it, like the CPU; else `f32`), the shared types,
/// the shared cell code and the pass.
pub fn compute_source(pass: &str, f64_decider: bool) -> String {
    let real = if f64_decider { "f64" } else { "f32" };
    format!("alias real = {real};\n{TYPES}\n{CELL}\n{pass}")
}

/// The render module of one pass: the shared types, the shared drawing
/// code and the pass.
pub fn render_source(pass: &str) -> String {
    format!("{TYPES}\n{DRAW}\n{pass}")
}

/// The module of one pre-integrated pass: [`render_source`] with the
/// pre-integrated passes' shared code before the pass.
pub fn pre_source(pass: &str) -> String {
    render_source(&format!("{PRE}\n{pass}"))
}

/// Every module the program builds, by name (with the f64 decider).
pub fn all_modules() -> Vec<(&'static str, String)> {
    vec![
        ("count.wgsl", compute_source(COUNT, true)),
        ("scan.wgsl", compute_source(SCAN, true)),
        ("emit.wgsl", compute_source(EMIT, true)),
        ("bin.wgsl", compute_source(BIN, true)),
        ("count.wgsl (f32 decider)", compute_source(COUNT, false)),
        ("emit.wgsl (f32 decider)", compute_source(EMIT, false)),
        ("slices.wgsl", render_source(SLICES)),
        ("pre_slab.wgsl", pre_source(PRE_SLAB)),
        ("pre_surface.wgsl", pre_source(PRE_SURFACE)),
        ("pre_front.wgsl", pre_source(PRE_FRONT)),
        ("present.wgsl", PRESENT.to_string()),
        ("shared/types.wgsl", TYPES.to_string()),
    ]
}

/// Parses and validates a module with naga (all validation flags; f64
/// allowed), returning the module or a readable error.
pub fn validate(name: &str, src: &str) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(src)
        .map_err(|e| format!("{name}: {}", e.emit_to_string(src)))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::FLOAT64,
    )
    .validate(&module)
    .map_err(|e| format!("{name}: {}", e.emit_to_string(src)))?;
    Ok(module)
}

/// A shader module on `device` from `src`, validated with naga first (a
/// readable error instead of wgpu's panic).
pub fn module(
    device: &wgpu::Device,
    name: &str,
    src: &str,
) -> Result<wgpu::ShaderModule, GpuError> {
    validate(name, src).map_err(|e| GpuError::Device(format!("invalid shader {e}")))?;
    Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(name),
        source: wgpu::ShaderSource::Wgsl(src.into()),
    }))
}
