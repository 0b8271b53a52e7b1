//! `stratasweep render`: volume rendering, slices and isosurfaces to PNG.
//! The flags become the library's render request; the policy
//! ([`stratasweep::policy::render`]) validates it, checks it against the
//! loaded grid and draws it; this command loads, prints and writes.

use super::checks::{self as cli_checks, Flags, Outputs, policy_error};
use super::common::*;
use super::device::*;
use super::scene_args::{SceneArgs, print_z_scale};
use anyhow::Context;
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;
use stratasweep::gpu::render::Mode;
use stratasweep::gpu::render::Renderer;
use stratasweep::io::guard::Named;
use stratasweep::policy::render::{Level, Target, blank_warning};
use stratasweep::structures::StructureChoice;

/// `stratasweep render`.
#[derive(Args)]
pub(crate) struct RenderArgs {
    #[command(flatten)]
    pub(crate) input: GridArg,
    /// Output PNG (straight RGBA).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    #[command(flatten)]
    pub(crate) scene: SceneArgs,
    /// Draw the colour legend (property, value range) into the PNG, as the viewer shows it.
    #[arg(long)]
    pub(crate) legend: bool,
}

/// `stratasweep render`.
pub(crate) fn cmd_render(a: RenderArgs, quiet: bool) -> Result<()> {
    let req = a.scene.request(Target::Image, a.legend)?;
    let outputs = Outputs::default().add("-o", Some(&a.output));
    let transfer_file = req
        .transfer
        .file()
        .map(|f| Named::new("the transfer function", f));
    outputs.check_before(a.input.grid.as_deref(), transfer_file.as_slice())?;
    cli_checks::output_ext("-o", &a.output, &["png"])?;
    let plan = req.resolve().map_err(policy_error)?;
    let o = &plan.options;
    let (grid, name, _, _, ijk) = load_with_info(&a.input, quiet, &outputs)?;
    let z_scale = print_z_scale(plan.z_scale(&grid), &grid, quiet);
    // Corner-point input keeps its IJK lattice: Auto then picks the
    // corner-point graph, as `slice` does (faster to build and sweep than
    // the CGraph, the same slices), and pre-integrated slabs march its
    // cells in index space.
    let s = build_structure(&grid, StructureChoice::Auto, ijk.as_ref(), &name, quiet)?;
    s.cell_notes().iter().for_each(|n| eprintln!("note: {n}"));
    for n in plan.check_grid(&grid).map_err(policy_error)? {
        let level = match n.level {
            Level::Warning => "warning",
            Level::Note => "note",
        };
        eprintln!("{level}: {}", n.text.spelled(&Flags));
    }
    let ctx = open(&a.scene.adapter, quiet)?;
    let mut r = Renderer::new(&ctx).map_err(|e| match backend_chosen() {
        Some(hint) => anyhow::Error::new(e).context(hint),
        None => e.into(),
    })?;
    let t = Instant::now();
    let drawn = plan.draw(&mut r, &grid, &s, z_scale)?;
    let secs = t.elapsed().as_secs_f64();
    if let Some(why) = &drawn.fallback {
        eprintln!("note: pre-integrated slabs without the index-space field ({why})");
    }
    if drawn.blank {
        let w = blank_warning(&a.output.display().to_string());
        eprintln!("warning: {}", w.spelled(&Flags));
    }
    stratasweep::io::atomic::write_bytes(&a.output, &drawn.image.png()?)
        .with_context(|| format!("cannot write {}", a.output.display()))?;
    if !quiet {
        let what = match o.mode {
            Mode::Iso => format!("{} isovalue(s)", o.iso.len()),
            _ => format!("{} slices", o.slices),
        };
        eprintln!(
            "{name}: {:?} mode, {what}, {}x{} in {:.3} s ({} compute dispatches); wrote {}",
            a.scene.mode,
            o.size.0,
            o.size.1,
            secs,
            drawn.dispatches,
            a.output.display()
        );
    }
    Ok(())
}
