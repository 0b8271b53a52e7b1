//! WGSL sources (one file per pass in `wgsl/`, shared code in
//! `wgsl/shared/`), their composition into modules, and naga validation.

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
/// Render pass (volume, slices, iso).
pub const RENDER: &str = include_str!("../../wgsl/render.wgsl");
/// Present pass (the viewer's float target over the background).
pub const PRESENT: &str = include_str!("../../wgsl/present.wgsl");

/// The compute module of one pass: the decider precision alias (`f64`
/// when the adapter has it, like the CPU; else `f32`), the shared types,
/// the shared cell code and the pass.
pub fn compute_source(pass: &str, f64_decider: bool) -> String {
    let real = if f64_decider { "f64" } else { "f32" };
    format!("alias real = {real};\n{TYPES}\n{CELL}\n{pass}")
}

/// The render module: shared types and the render pass.
pub fn render_source() -> String {
    format!("{TYPES}\n{RENDER}")
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
        ("render.wgsl", render_source()),
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
