//! What every command shares: the grid argument and loading, structure and level arguments, progress bars.

use super::checks::{self as cli_checks, Outputs};
use anyhow::Context;
use anyhow::Result;
use anyhow::bail;
use clap::Args;
use clap::ValueEnum;
use indicatif::ProgressBar;
use indicatif::ProgressStyle;
use serde_json::Value;
use std::path::PathBuf;
use std::time::Instant;
use stratasweep::field::FieldSpec;
use stratasweep::generate;
use stratasweep::grid::Grid;
use stratasweep::grid::IjkLayout;
use stratasweep::io;
use stratasweep::pipeline::LevelSpec;
use stratasweep::structures::{Structure, StructureChoice};
use stratasweep::sweep::SweepOptions;

/// Cells per axis of the built-in demo grid (`--demo`).
pub(crate) const DEMO_DIMS: [usize; 3] = [64, 64, 64];

#[derive(Args)]
pub(crate) struct GridArg {
    /// Grid file (.vtk legacy, .vtu, .vts; Eclipse .grdecl, .DATA, .inc, .EGRID).
    pub(crate) grid: Option<PathBuf>,
    /// Use the built-in demo grid (a warped 64³ curvilinear grid carrying the Marschner–Lobb signal `f`).
    #[arg(long, conflicts_with = "grid")]
    pub(crate) demo: bool,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
pub(crate) enum StructureArg {
    Auto,
    Cgraph,
    Scgraph,
    Bruteforce,
    /// CIEL half-edges (any polyhedral grid).
    Ciel,
    /// The corner-point graph (corner-point input; auto picks it there).
    Cpgraph,
}

impl From<StructureArg> for StructureChoice {
    fn from(s: StructureArg) -> Self {
        match s {
            StructureArg::Auto => StructureChoice::Auto,
            StructureArg::Cgraph => StructureChoice::CGraph,
            StructureArg::Scgraph => StructureChoice::SCGraph,
            StructureArg::Bruteforce => StructureChoice::BruteForce,
            StructureArg::Ciel => StructureChoice::Ciel,
            StructureArg::Cpgraph => StructureChoice::CpGraph,
        }
    }
}

#[derive(Args)]
#[group(id = "what", required = true, multiple = false)]
pub(crate) struct FieldArgs {
    /// Planes orthogonal to an axis: x, y, z, -x, -y, -z.
    #[arg(long, group = "what", allow_hyphen_values = true)]
    pub(crate) axis: Option<String>,
    /// Planes with normal a,b,c (normalised; levels are signed distances).
    #[arg(long, group = "what", allow_hyphen_values = true)]
    pub(crate) normal: Option<String>,
    /// Isosurfaces of this vertex property (a cell property is averaged to the vertices, volume-weighted).
    #[arg(long, group = "what")]
    pub(crate) property: Option<String>,
}

#[derive(Args)]
#[group(id = "levels", required = true, multiple = false)]
pub(crate) struct LevelArgs {
    /// K levels at t_k = lo + (k + 0.5)(hi − lo)/K over the field's range.
    #[arg(long, group = "levels")]
    pub(crate) count: Option<usize>,
    /// Levels FROM:TO:STEP in world units (inclusive).
    #[arg(long, group = "levels", allow_hyphen_values = true)]
    pub(crate) values: Option<String>,
}

/// Loads the grid (see [`load_with_info`]).
pub(crate) fn load(input: &GridArg, quiet: bool, outputs: &Outputs) -> Result<(Grid, String, f64)> {
    let (g, n, s, _, _) = load_with_info(input, quiet, outputs)?;
    Ok((g, n, s))
}

/// A loaded grid, its name, the load time, and (corner-point input) the
/// conversion report and the IJK layout.
pub(crate) type LoadedGrid = (Grid, String, f64, Option<Value>, Option<IjkLayout>);

/// Loads the grid; `outputs` are refused before the read when they name the
/// grid file (or an EGRID's INIT) and after it when they name any file the
/// load read (INCLUDEs), so nothing is written over an input.
pub(crate) fn load_with_info(
    input: &GridArg,
    quiet: bool,
    outputs: &Outputs,
) -> Result<LoadedGrid> {
    outputs.check_before(input.grid.as_deref(), &[])?;
    let t = Instant::now();
    let mut info = None;
    let mut ijk = None;
    let (grid, name) = if input.demo {
        (
            generate::warped(DEMO_DIMS, 1),
            format!(
                "demo (warped {}x{}x{})",
                DEMO_DIMS[0], DEMO_DIMS[1], DEMO_DIMS[2]
            ),
        )
    } else {
        let Some(path) = &input.grid else {
            bail!("give a grid file, or --demo for the built-in grid")
        };
        let sp = spinner(quiet, format!("reading {}", path.display()));
        let loaded = io::load(path).with_context(|| format!("cannot load {}", path.display()))?;
        outputs.check_after(&loaded.inputs)?;
        for w in &loaded.warnings {
            eprintln!("warning: {}", io::checks::escape_control(w));
        }
        info = loaded.cornerpoint;
        ijk = loaded.ijk;
        let g = loaded.grid;
        sp.finish_and_clear();
        (g, path.display().to_string())
    };
    grid.validate()
        .with_context(|| format!("invalid grid {name}"))?;
    Ok((grid, name, t.elapsed().as_secs_f64(), info, ijk))
}

/// Builds the sweep structure of the loaded grid `name` (a spinner meanwhile:
/// a multi-million-cell corner-point grid takes a second or more).
pub(crate) fn build_structure(
    grid: &Grid,
    choice: StructureChoice,
    ijk: Option<&IjkLayout>,
    name: &str,
    quiet: bool,
) -> Result<Structure> {
    let sp = spinner(quiet, format!("building the sweep structure of {name}"));
    let s = Structure::build_with(grid, choice, ijk)
        .with_context(|| format!("cannot build a structure for {name}"));
    sp.finish_and_clear();
    s
}

/// The sweep's A/B knobs, which only the CLI reads from the environment:
/// `STRATASWEEP_CELL_LOOP=1` (the per-cell lattice loop) and
/// `STRATASWEEP_PATCH_WIDTH=w` (the chunked loop's patch width).
pub(crate) fn sweep_options_from_env() -> SweepOptions {
    SweepOptions {
        per_cell_loop: std::env::var_os("STRATASWEEP_CELL_LOOP").is_some(),
        patch_width: std::env::var("STRATASWEEP_PATCH_WIDTH")
            .ok()
            .and_then(|w| w.parse().ok()),
        ..Default::default()
    }
}

pub(crate) fn spinner(quiet: bool, msg: String) -> ProgressBar {
    crate::oom_context(&msg);
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new_spinner();
    pb.set_message(msg);
    pb.enable_steady_tick(std::time::Duration::from_millis(120));
    pb
}

pub(crate) fn bar(quiet: bool, len: u64, msg: &str) -> ProgressBar {
    crate::oom_context(msg);
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}")
            .unwrap(),
    );
    pb.set_message(msg.to_string());
    pb
}

pub(crate) fn parse_triplet(s: &str, what: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} '{s}': expected three comma-separated numbers"))?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        bail!("{what} '{s}': expected three finite comma-separated numbers");
    }
    Ok([v[0], v[1], v[2]])
}

pub(crate) fn parse_axis(s: &str) -> Result<FieldSpec> {
    FieldSpec::parse_axis(s)
        .ok_or_else(|| anyhow::anyhow!("--axis '{s}': expected x, y, z, -x, -y or -z"))
}

pub(crate) fn field_spec(f: &FieldArgs) -> Result<FieldSpec> {
    if let Some(a) = &f.axis {
        return parse_axis(a);
    }
    if let Some(n) = &f.normal {
        let n = parse_triplet(n, "--normal")?;
        if n.iter().all(|&c| c == 0.0) {
            bail!("--normal must not be zero");
        }
        return Ok(FieldSpec::Normal(n));
    }
    Ok(FieldSpec::Property(f.property.clone().expect("clap group")))
}

pub(crate) fn level_spec(l: &LevelArgs) -> Result<LevelSpec> {
    if let Some(k) = l.count {
        cli_checks::check_count(k)?;
        return Ok(LevelSpec::Count(k));
    }
    let s = l.values.as_deref().expect("clap group");
    Ok(LevelSpec::Values(cli_checks::values_levels(s)?))
}
