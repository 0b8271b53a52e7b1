//! `stratasweep render`: volume rendering, slices and isosurfaces to PNG.

use super::checks::{self as cli_checks, Outputs};
use super::common::*;
use super::device::*;
use super::scene_args::SceneArgs;
use anyhow::Context;
use anyhow::Result;
use anyhow::bail;
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;
use stratasweep::gpu::render::Mode;
use stratasweep::gpu::render::Renderer;
use stratasweep::gpu::render::TransferSource;
use stratasweep::io::guard::Named;
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
    cli_checks::check_slices(a.scene.slices)?;
    let outputs = Outputs::default().add("-o", Some(&a.output));
    let transfer_file = matches!(
        TransferSource::parse(&a.scene.transfer),
        Ok(TransferSource::File(_))
    )
    .then(|| Named::new("the transfer function", &a.scene.transfer));
    outputs.check_before(a.input.grid.as_deref(), transfer_file.as_slice())?;
    cli_checks::output_ext("-o", &a.output, &["png"])?;
    let mut o = a.scene.options()?;
    super::render_checks::check_mode_flags(&o, &a.scene)?;
    if a.scene.cells.is_none() {
        // The same PNG bits on every run (see `--cells`).
        o.cells = stratasweep::gpu::render::CellFinding::Sweep;
    }
    if o.mode == Mode::Iso && o.iso.is_empty() {
        bail!("--mode iso needs --iso VALUES (comma-separated)");
    }
    let (grid, name, _, _, ijk) = load_with_info(&a.input, quiet, &outputs)?;
    let z_scale = a.scene.z_scale(&grid, quiet);
    // Corner-point input keeps its IJK lattice: Auto then picks the
    // corner-point graph, as `slice` does (faster to build and sweep than
    // the CGraph, the same slices), and pre-integrated slabs march its
    // cells in index space.
    let s = build_structure(&grid, StructureChoice::Auto, ijk.as_ref(), &name, quiet)?;
    s.cell_notes().iter().for_each(|n| eprintln!("note: {n}"));
    super::render_checks::check_before(&grid, &o, &a.scene)?;
    let ctx = open(&a.scene.adapter, quiet)?;
    let mut r = Renderer::new(&ctx).map_err(|e| match backend_chosen() {
        Some(hint) => anyhow::Error::new(e).context(hint),
        None => e.into(),
    })?;
    r.set_preintegrated(a.scene.preintegrated);
    let t = Instant::now();
    let img = r.render_exaggerated(&grid, &s, &o, z_scale)?;
    let img = if a.legend {
        super::view::legend_onto(&ctx, &r, &grid, &o, img)?
    } else {
        img
    };
    let secs = t.elapsed().as_secs_f64();
    if let Some(why) = pre_fallback(&r, &grid, &o) {
        eprintln!("note: pre-integrated slabs without the index-space field ({why})");
    }
    if super::render_checks::is_blank(&img) {
        eprintln!(
            "warning: nothing was drawn: every pixel of {} is the background (check --property, --transfer, --iso and --view-dir)",
            a.output.display()
        );
    }
    stratasweep::io::atomic::write_bytes(&a.output, &img.png()?)
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
            r.dispatches(),
            a.output.display()
        );
    }
    Ok(())
}

/// Why a pre-integrated volume frame did not march the property in index
/// space (the slices' reason), if it did not.
fn pre_fallback(
    r: &Renderer,
    grid: &stratasweep::grid::Grid,
    o: &stratasweep::gpu::render::RenderOptions,
) -> Option<String> {
    use stratasweep::gpu::render::{camera::slicing_axis, slice_cache::slice_key};
    if !r.preintegrated() || o.mode != Mode::Volume {
        return None;
    }
    let d = glam::Vec3::from_array(o.view_dir.map(|c| c as f32)).normalize();
    let k = slice_key(grid, o, slicing_axis(d))
        .ok()?
        .with_attr_gradient();
    r.slices(&k.key)?.field_fallback.clone()
}
