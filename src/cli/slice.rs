//! `stratasweep slice`: slices and isosurfaces to PLY/VTP with statistics.

use super::checks::{self as cli_checks, Outputs, policy_error};
use super::common::*;
use super::device::*;
use anyhow::Context;
use anyhow::Result;
use anyhow::bail;
use clap::Args;
use clap::ValueEnum;
use std::path::PathBuf;
use std::time::Instant;
use stratasweep::io;
use stratasweep::pipeline::LevelSpec;
use stratasweep::pipeline::SliceRequest;
use stratasweep::pipeline::slice;
use stratasweep::policy::device::{slice_device, slice_device_on};
use stratasweep::report::flatten_by_cell;
use stratasweep::report::stats_json;
use stratasweep::structures::Structure;

#[derive(Args)]
pub(crate) struct SliceArgs {
    #[command(flatten)]
    pub(crate) input: GridArg,
    #[command(flatten)]
    pub(crate) field: FieldArgs,
    #[command(flatten)]
    pub(crate) levels: LevelArgs,
    /// Structure to sweep with.
    #[arg(long, value_enum, default_value = "auto")]
    pub(crate) structure: StructureArg,
    /// Spatial blocks swept in parallel (output is identical to 1 thread).
    #[arg(long, default_value_t = 1)]
    pub(crate) threads: usize,
    /// Property interpolated onto the polygons (default: the contoured property, else the first point property).
    #[arg(long)]
    pub(crate) attribute: Option<String>,
    /// Output mesh: .ply (binary) or .vtp (VTK XML PolyData).
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    /// Statistics JSON.
    #[arg(long)]
    pub(crate) stats: Option<PathBuf>,
    /// Polygon generation: cpu, gpu (CPU sweep, GPU emission; statistics only), auto (gpu if an adapter exists).
    #[arg(long, value_enum, default_value = "cpu")]
    pub(crate) device: DeviceArg,
    /// GPU adapter name (substring); `WGPU_BACKEND` picks backends.
    #[arg(long)]
    pub(crate) adapter: Option<String>,
    /// Where a cell property (--attribute, else --property) is carried:
    /// `vertices` = volume-weighted average over the cells that really share
    /// each vertex (never across a fault); `cells` = flat, one value per
    /// polygon from its source cell (polygon vertices are then not shared).
    #[arg(long, value_enum, default_value = "vertices")]
    pub(crate) at: AtArg,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
pub(crate) enum AtArg {
    Vertices,
    Cells,
}

/// A pipeline warning in the CLI's words: the levels it suggests become
/// `--values FROM:TO:STEP` with the step of `values` (as given).
fn flag_words(w: &str, values: Option<&str>) -> String {
    let step = values.and_then(|v| v.rsplit(':').next().filter(|_| v.matches(':').count() == 2));
    match w.rsplit_once("take the levels ") {
        Some((head, levels)) => {
            let (a, b) = levels.split_once("..").unwrap_or((levels, levels));
            match step {
                Some(st) => format!(
                    "{}: did you mean --values {a}:{b}:{}?",
                    head.trim_end(),
                    st.trim()
                ),
                None => format!("{}: did you mean the levels {levels}?", head.trim_end()),
            }
        }
        None => w.to_string(),
    }
}

pub(crate) fn cmd_slice(a: SliceArgs, quiet: bool) -> Result<()> {
    let field = field_spec(&a.field)?;
    let levels = level_spec(&a.levels)?;
    cli_checks::check_threads(a.threads)?;
    let outputs = Outputs::default()
        .add("-o", a.output.as_deref())
        .add("--stats", a.stats.as_deref());
    outputs.check_before(a.input.grid.as_deref(), &[])?;
    let ext = match &a.output {
        Some(o) => Some(cli_checks::output_ext("-o", o, &["ply", "vtp"])?),
        None => None,
    };
    let device = slice_device(a.device.into(), a.output.is_some(), a.structure.into())
        .map_err(policy_error)?;
    let (grid, name, load_s, _, ijk) = load_with_info(&a.input, quiet, &outputs)?;
    let t = Instant::now();
    let s = build_structure(&grid, a.structure.into(), ijk.as_ref(), &name, quiet)?;
    s.cell_notes().iter().for_each(|n| eprintln!("note: {n}"));
    let build_s = t.elapsed().as_secs_f64();
    let nlev = match &levels {
        LevelSpec::Count(k) => *k,
        LevelSpec::Values(v) => v.len(),
    };
    let blocks = if a.structure == StructureArg::Bruteforce || matches!(s, Structure::Ciel(_)) {
        1
    } else {
        a.threads
    };
    let pb = bar(quiet, (nlev * blocks) as u64, "slicing");
    let req = SliceRequest {
        field: field.clone(),
        levels,
        attribute: a.attribute.clone(),
        threads: a.threads,
        brute_force: a.structure == StructureArg::Bruteforce,
        collect_mesh: a.output.is_some(),
        sweep: sweep_options_from_env(),
    };
    let inc = |n: usize| pb.inc(n as u64);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads)
        .build()?;
    let device = slice_device_on(device, &s).map_err(policy_error)?;
    let gpu = pool
        .install(|| slice_gpu(device, &a.adapter, &grid, &s, &req, quiet))
        .with_context(|| format!("cannot slice {name} on the GPU"))?;
    let r = match gpu {
        Some(r) => r,
        None => pool
            .install(|| slice(&grid, &s, &req, &inc))
            .with_context(|| format!("cannot slice {name}"))?,
    };
    pb.finish_and_clear();
    for w in &r.warnings {
        eprintln!(
            "warning: {}",
            io::checks::escape_control(&flag_words(w, a.levels.values.as_deref()))
        );
    }
    let stats = stats_json(&r, &s, &grid, load_s, build_s, &name, &field);
    // The statistics are written in full before the mesh replaces anything
    // and renamed after it: a failure of either leaves both files as they
    // were.
    let stats_file = match &a.stats {
        Some(p) => Some((p, super::write::prepare_json(p, &stats)?)),
        None => None,
    };
    if let Some(out) = &a.output {
        let mesh = r.mesh.as_ref().expect("collected");
        let flat;
        let mesh = if a.at == AtArg::Cells {
            let name = a.attribute.clone().or(a.field.property.clone());
            let Some(p) = name.as_deref().and_then(|n| grid.cell_property(n)) else {
                bail!("--at cells needs a cell property named by --attribute or --property");
            };
            let vals: Vec<f64> = (0..p.len()).map(|i| p.scalar_at(i)).collect();
            flat = flatten_by_cell(mesh, &vals);
            &flat
        } else {
            mesh
        };
        let sp = spinner(quiet, format!("writing {}", out.display()));
        match ext.as_deref() {
            Some("ply") => io::writers::write_ply(out, mesh)?,
            _ => io::writers::write_vtp(out, mesh)?,
        }
        sp.finish_and_clear();
    }
    if let Some((p, f)) = stats_file {
        f.commit()
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    if !quiet {
        let t = &stats["totals"];
        eprintln!(
            "{name}: {} levels, {} cut cells, {} polygons, {} minima; build {:.3}s, minima {:.3}s, sweep {:.3}s ({:.1} M cut cells/s)",
            nlev,
            t["cells"],
            t["polygons"],
            r.minima,
            build_s,
            r.timings.minima,
            r.timings.sweep,
            t["cells"].as_f64().unwrap_or(0.0) / r.timings.sweep.max(1e-9) / 1e6
        );
        if let Some(o) = &a.output {
            eprintln!("wrote {}", o.display());
        }
    }
    Ok(())
}
