//! The `stratasweep` command line: info, slice, generate, bench, render, view.

mod cli_checks;
mod cli_write;
mod gpu_cmd;
mod render_checks;
mod scene_args;
mod view;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{Value, json};

use stratasweep::field::FieldSpec;
use stratasweep::grid::{Grid, Topology};
use stratasweep::pipeline::{LevelSpec, SliceRequest, SliceResult, slice};
use stratasweep::report::{flatten_by_cell, memory_json, stats_json};
use stratasweep::structures::cpgraph::IjkLayout;
use stratasweep::structures::{Structure, StructureChoice};
use stratasweep::sweep::SweepOptions;
use stratasweep::{generate, io};

use cli_checks::Outputs;

/// Cells per axis of the built-in demo grid (`--demo`).
const DEMO_DIMS: [usize; 3] = [64, 64, 64];

#[derive(Parser)]
#[command(
    name = "stratasweep",
    version,
    about = "Incremental slicing and contouring of geological grids (Caumon et al. 2005)"
)]
struct Cli {
    /// No progress bars or chatter.
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Print vertices, cells by type, the meta-cell catalog and memory per structure.
    Info(InfoArgs),
    /// Slice or contour a grid with the incremental sweep.
    Slice(SliceArgs),
    /// Write a synthetic grid.
    #[command(subcommand)]
    Generate(GenCmd),
    /// Benchmark the sweep against the brute-force reference (or, with --device, CPU against GPU emission).
    Bench(BenchArgs),
    /// Volume-render (or draw isosurfaces of) a grid on the GPU into a PNG.
    Render(gpu_cmd::RenderArgs),
    /// Open an interactive window (orbit, pan, zoom; egui panel) on a grid, drawn on the GPU.
    View(view::ViewArgs),
}

#[derive(Args)]
struct GridArg {
    /// Grid file (.vtk legacy, .vtu, .vts; Eclipse .grdecl, .DATA, .inc, .EGRID).
    grid: Option<PathBuf>,
    /// Use the built-in demo grid (a warped 64³ curvilinear grid carrying the Marschner–Lobb signal `f`).
    #[arg(long, conflicts_with = "grid")]
    demo: bool,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
enum StructureArg {
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
struct InfoArgs {
    #[command(flatten)]
    input: GridArg,
    /// Structure whose memory is reported.
    #[arg(long, value_enum, default_value = "auto")]
    structure: StructureArg,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
#[group(id = "what", required = true, multiple = false)]
struct FieldArgs {
    /// Planes orthogonal to an axis: x, y, z, -x, -y, -z.
    #[arg(long, group = "what", allow_hyphen_values = true)]
    axis: Option<String>,
    /// Planes with normal a,b,c (normalised; levels are signed distances).
    #[arg(long, group = "what", allow_hyphen_values = true)]
    normal: Option<String>,
    /// Isosurfaces of this vertex property (a cell property is averaged to the vertices, volume-weighted).
    #[arg(long, group = "what")]
    property: Option<String>,
}

#[derive(Args)]
#[group(id = "levels", required = true, multiple = false)]
struct LevelArgs {
    /// K levels at t_k = lo + (k + 0.5)(hi − lo)/K over the field's range.
    #[arg(long, group = "levels")]
    count: Option<usize>,
    /// Levels FROM:TO:STEP in world units (inclusive).
    #[arg(long, group = "levels", allow_hyphen_values = true)]
    values: Option<String>,
}

#[derive(Args)]
struct SliceArgs {
    #[command(flatten)]
    input: GridArg,
    #[command(flatten)]
    field: FieldArgs,
    #[command(flatten)]
    levels: LevelArgs,
    /// Structure to sweep with.
    #[arg(long, value_enum, default_value = "auto")]
    structure: StructureArg,
    /// Spatial blocks swept in parallel (output is identical to 1 thread).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Property interpolated onto the polygons (default: the contoured property, else the first point property).
    #[arg(long)]
    attribute: Option<String>,
    /// Output mesh: .ply (binary) or .vtp (VTK XML PolyData).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Statistics JSON.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Polygon generation: cpu, gpu (CPU sweep, GPU emission; statistics only), auto (gpu if an adapter exists).
    #[arg(long, value_enum, default_value = "cpu")]
    device: gpu_cmd::DeviceArg,
    /// GPU adapter name (substring); `WGPU_BACKEND` picks backends.
    #[arg(long)]
    adapter: Option<String>,
    /// Where a cell property (--attribute, else --property) is carried:
    /// `vertices` = volume-weighted average over the cells that really share
    /// each vertex (never across a fault); `cells` = flat, one value per
    /// polygon from its source cell (polygon vertices are then not shared).
    #[arg(long, value_enum, default_value = "vertices")]
    at: AtArg,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
enum AtArg {
    Vertices,
    Cells,
}

#[derive(Subcommand)]
enum GenCmd {
    /// A smoothly warped, non-axis-aligned curvilinear grid with the Marschner–Lobb signal `f` (.vts).
    Warped {
        /// Cells per axis NI,NJ,NK.
        #[arg(long)]
        dims: String,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output .vts.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// A clipped 3D Voronoi grid of random sites in the unit box: conforming VTK polyhedra with a smooth point property `f` (.vtu).
    Voronoi {
        /// Number of cells (sites).
        #[arg(long)]
        cells: usize,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output .vtu.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// A faulted corner-point reservoir (folded layers, faults with throw, pinch-outs, inactive cells, PORO) as GRDECL.
    Faulted {
        /// Cells NI,NJ,NK.
        #[arg(long)]
        dims: String,
        /// Number of faults.
        #[arg(long, default_value_t = 3)]
        faults: usize,
        /// Dip of every fault in degrees (45–90; 90 = vertical). Default: the
        /// first fault vertical, the others inclined 50–80°.
        #[arg(long)]
        fault_dip: Option<f64>,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output .grdecl.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// A conforming mixed tet/pyramid/wedge/hex grid with a noisy point property `f` (.vtu).
    Zoo {
        /// Approximate cell count.
        #[arg(long)]
        cells: usize,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output .vtu.
        #[arg(short, long)]
        output: PathBuf,
    },
}

#[derive(Args)]
struct BenchArgs {
    #[command(flatten)]
    input: GridArg,
    /// Axis to slice along.
    #[arg(long, default_value = "z", allow_hyphen_values = true)]
    axis: String,
    /// Number of levels.
    #[arg(long, default_value_t = 200)]
    count: usize,
    /// Structure for the sweep (brute force always runs on the same cells).
    #[arg(long, value_enum, default_value = "auto")]
    structure: StructureArg,
    /// Spatial blocks in parallel.
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Timed repetitions (best is reported).
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Skip the brute-force run (slow on big grids).
    #[arg(long)]
    no_brute_force: bool,
    /// The paper's law: time per level against cut cells over generated warped grids of these sizes (cells per axis).
    #[arg(long, value_delimiter = ',')]
    law: Option<Vec<usize>>,
    /// The law for CIEL: as --law over generated Voronoi grids of these cell counts (structure ciel).
    #[arg(long, value_delimiter = ',')]
    law_voronoi: Option<Vec<usize>>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// Compare polygon generation paths instead: cpu (1 and all threads) and/or gpu.
    #[arg(long, value_delimiter = ',')]
    device: Option<Vec<String>>,
    /// GPU adapter name (substring).
    #[arg(long)]
    adapter: Option<String>,
    /// Corner-point input only: time the parse (one core) and the
    /// conversion to a zoo grid, then stop.
    #[arg(long)]
    load_only: bool,
    /// With --load-only: stop before building the sweep structure (so that
    /// `/usr/bin/time -v` measures the load alone).
    #[arg(long)]
    skip_build: bool,
}

fn main() {
    restore_default_sigpipe();
    tune_allocator();
    quiet_headless_vulkan_layer();
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        // Messages may quote file content: never send raw control bytes.
        eprintln!("error: {}", io::checks::escape_control(&error_chain(&e)));
        std::process::exit(1);
    }
}

/// Lets a closed stdout end the process quietly, as it does for other
/// command-line tools (`stratasweep info G --json | head -1`): Rust ignores
/// SIGPIPE, which turns the write into a panic in `println!`.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread exists;
    // SIG_DFL is a valid disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Turns off Mesa's Vulkan device-selection layer on machines without a
/// desktop session (no `XDG_RUNTIME_DIR`: servers, containers, CI), unless
/// the user configured it. The layer only reorders the adapter list, which
/// `GpuContext` sorts itself, but it connects to Wayland to do so and there
/// prints "error: XDG_RUNTIME_DIR is invalid or not set" twice per run: a
/// false alarm on the README's first command.
fn quiet_headless_vulkan_layer() {
    let set = |k: &str| std::env::var_os(k).is_some();
    if cfg!(target_os = "linux")
        && !set("XDG_RUNTIME_DIR")
        && !set("NODEVICE_SELECT")
        && !set("MESA_VK_DEVICE_SELECT")
    {
        // SAFETY: called first thing in main, before any thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// Tunes glibc's allocator for this process's pattern: arrays of tens to
/// hundreds of MiB that grow, are freed and are allocated again (parsing,
/// conversion, build, sweep buffers). By default each one above the dynamic
/// mmap threshold is a fresh mapping whose pages fault in again; kept in
/// the heap (freed memory above 256 MiB is still trimmed) they are reused.
/// Measured: parsing the generated 4M-cell GRDECL 592 MB/s instead of
/// 286 MB/s; with the same settings through `GLIBC_TUNABLES`, Reek `.DATA`
/// load + build had 3,530 page faults instead of 4,380.
fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: called first thing in main, before any thread or allocation
    // of ours; mallopt only changes allocator parameters.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 256 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
        libc::mallopt(libc::M_TOP_PAD, 32 << 20);
    }
}

/// The error and its causes joined by ": ", skipping a cause whose text
/// its predecessor already ends with (errors that print their source), and
/// a cause's leading X when the text so far ends with X and the cause goes
/// on with ':' ("cannot load a.vtk" then "a.vtk: invalid grid" or
/// "a.vtk:3: …" names the file once). Nothing is lost: the text so far
/// still ends with X.
fn error_chain(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if msg.ends_with(&c) {
            continue;
        }
        // The longest tail of msg after a space that c starts with, then ':'.
        let repeated = msg
            .match_indices(' ')
            .map(|(i, _)| &msg[i + 1..])
            .find(|tail| {
                !tail.is_empty() && c.starts_with(tail) && c[tail.len()..].starts_with(':')
            })
            .map_or(0, str::len);
        if repeated == 0 {
            msg.push_str(": ");
            msg.push_str(&c);
        } else {
            msg.push_str(&c[repeated..]);
        }
    }
    msg
}

fn run(cli: Cli) -> Result<()> {
    let quiet = cli.quiet;
    match cli.cmd {
        Cmd::Info(a) => cmd_info(a),
        Cmd::Slice(a) => cmd_slice(a, quiet),
        Cmd::Generate(g) => cmd_generate(g, quiet),
        Cmd::Bench(a) => cmd_bench(a, quiet),
        Cmd::Render(a) => gpu_cmd::cmd_render(a, quiet),
        Cmd::View(a) => view::cmd_view(a, quiet),
    }
}

/// Loads the grid (see [`load_with_info`]).
fn load(input: &GridArg, quiet: bool, outputs: &Outputs) -> Result<(Grid, String, f64)> {
    let (g, n, s, _, _) = load_with_info(input, quiet, outputs)?;
    Ok((g, n, s))
}

/// A loaded grid, its name, the load time, and (corner-point input) the
/// conversion report and the IJK layout.
type LoadedGrid = (Grid, String, f64, Option<Value>, Option<IjkLayout>);

/// Loads the grid; `outputs` are refused before the read when they name the
/// grid file (or an EGRID's INIT) and after it when they name any file the
/// load read (INCLUDEs), so nothing is written over an input.
fn load_with_info(input: &GridArg, quiet: bool, outputs: &Outputs) -> Result<LoadedGrid> {
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

/// The sweep's A/B knobs, which only the CLI reads from the environment:
/// `STRATASWEEP_CELL_LOOP=1` (the per-cell lattice loop) and
/// `STRATASWEEP_PATCH_WIDTH=w` (the chunked loop's patch width).
fn sweep_options_from_env() -> SweepOptions {
    SweepOptions {
        per_cell_loop: std::env::var_os("STRATASWEEP_CELL_LOOP").is_some(),
        patch_width: std::env::var("STRATASWEEP_PATCH_WIDTH")
            .ok()
            .and_then(|w| w.parse().ok()),
    }
}

fn spinner(quiet: bool, msg: String) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new_spinner();
    pb.set_message(msg);
    pb.enable_steady_tick(std::time::Duration::from_millis(120));
    pb
}

fn bar(quiet: bool, len: u64, msg: &str) -> ProgressBar {
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

fn cmd_info(a: InfoArgs) -> Result<()> {
    let cpu0 = process_cpu_ns();
    let (grid, name, load_s, cp, ijk) = load_with_info(&a.input, true, &Outputs::default())?;
    let cpu1 = process_cpu_ns();
    let t = Instant::now();
    let s = Structure::build_with(&grid, a.structure.into(), ijk.as_ref())
        .with_context(|| format!("cannot build a structure for {name}"))?;
    let build_s = t.elapsed().as_secs_f64();
    let cpu2 = process_cpu_ns();
    let cpu_s = |a: Option<u64>, b: Option<u64>| match (a, b) {
        (Some(a), Some(b)) => Some(b.saturating_sub(a) as f64 * 1e-9),
        _ => None,
    };
    let out = stratasweep::report::info_json(
        &grid,
        &s,
        &stratasweep::report::InfoContext {
            name: name.clone(),
            cornerpoint: cp.clone(),
            load_s,
            build_s,
            load_cpu_s: cpu_s(cpu0, cpu1),
            build_cpu_s: cpu_s(cpu1, cpu2),
        },
    );
    let (nv, nc) = (grid.points.len(), grid.cell_count());
    let (hidden, bulk_volume) = (&out["hidden_cells"], &out["bulk_volume"]);
    let (lo, hi) = grid.bounds();
    let total = out["memory_bytes"]["total"].as_f64().unwrap_or(0.0);
    let split = &out["bytes_split"];
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!("{name}");
    println!("  vertices      {nv}");
    println!(
        "  cells         {nc} ({} live, {hidden} hidden)",
        s.live_cells()
    );
    for (k, v) in out["cell_types"].as_object().unwrap() {
        println!("    {k:<18} {v}");
    }
    println!("  cell classes  {}", out["cell_classes"]);
    let bow_ties = &out["self_intersecting_cells"];
    if bow_ties["count"].as_u64().unwrap_or(0) > 0 {
        println!(
            "  self-intersecting cells (a face crosses itself; not sliced): {}, first ids {}",
            bow_ties["count"], bow_ties["first"]
        );
    }
    println!("  bulk volume   {bulk_volume}");
    if let Some(i) = &cp {
        println!(
            "  corner-point  dims {} classes {}",
            i["dims"], i["classes"]
        );
        println!("    skipped keywords {}", i["input"]["skipped_keywords"]);
    }
    println!("  bounds        {lo:?} .. {hi:?}");
    println!(
        "  properties    point {} / cell {}",
        out["point_properties"], out["cell_properties"]
    );
    println!("  meta-cells");
    for m in out["meta_cells"].as_array().unwrap() {
        println!(
            "    {:<22} nv {:>2}  faces {:>2}  codes {:>5}  ambiguous {:>5}  table {} B  cells {}",
            m["name"].as_str().unwrap(),
            m["vertices"],
            m["faces"],
            m["codes"],
            m["ambiguous_codes"],
            m["table_bytes"],
            m["cells"]
        );
    }
    println!(
        "  structure     {} ({:.1} B/vertex, {:.1} B/cell in all; split {:.1} B/vertex + {:.1} B/cell)",
        s.name(),
        total / nv as f64,
        total / nc as f64,
        split["per_vertex"].as_f64().unwrap_or(0.0),
        split["per_cell"].as_f64().unwrap_or(0.0)
    );
    for (k, v) in out["memory_bytes"].as_object().unwrap() {
        println!("    {k:<30} {v}");
    }
    if !out["ciel"].is_null() {
        println!("  ciel          {}", out["ciel"]);
    }
    if !out["cpgraph"].is_null() {
        println!("  cpgraph       {}", out["cpgraph"]);
    }
    if !out["convex_split"].is_null() {
        println!("  convex split  {}", out["convex_split"]);
    }
    Ok(())
}

fn parse_triplet(s: &str, what: &str) -> Result<[f64; 3]> {
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

fn parse_axis(s: &str) -> Result<FieldSpec> {
    let (neg, a) = match s.strip_prefix('-') {
        Some(r) => (true, r),
        None => (false, s.strip_prefix('+').unwrap_or(s)),
    };
    let axis = match a {
        "x" | "X" => 0,
        "y" | "Y" => 1,
        "z" | "Z" => 2,
        _ => bail!("--axis '{s}': expected x, y, z, -x, -y or -z"),
    };
    Ok(FieldSpec::Axis {
        axis,
        negative: neg,
    })
}

fn field_spec(f: &FieldArgs) -> Result<FieldSpec> {
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

fn level_spec(l: &LevelArgs) -> Result<LevelSpec> {
    if let Some(k) = l.count {
        cli_checks::check_count(k)?;
        return Ok(LevelSpec::Count(k));
    }
    let s = l.values.as_deref().expect("clap group");
    Ok(LevelSpec::Values(cli_checks::values_levels(s)?))
}

fn cmd_slice(a: SliceArgs, quiet: bool) -> Result<()> {
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
    let (grid, name, load_s, _, ijk) = load_with_info(&a.input, quiet, &outputs)?;
    let t = Instant::now();
    let s = Structure::build_with(&grid, a.structure.into(), ijk.as_ref())
        .with_context(|| format!("cannot build a structure for {name}"))?;
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
    let device = match (a.device, &a.output, a.structure) {
        (gpu_cmd::DeviceArg::Gpu, Some(_), _) => {
            bail!("-o needs --device cpu: the GPU path gives statistics and draws, not mesh files")
        }
        (gpu_cmd::DeviceArg::Gpu, _, StructureArg::Bruteforce) => {
            bail!("--structure bruteforce runs on the CPU only")
        }
        (_, Some(_), _) | (_, _, StructureArg::Bruteforce) => gpu_cmd::DeviceArg::Cpu,
        // The GPU tables cover S-CGraph and CGraph grids; CIEL grids stay on the CPU.
        (gpu_cmd::DeviceArg::Auto, _, _) if matches!(s, Structure::Ciel(_)) => {
            gpu_cmd::DeviceArg::Cpu
        }
        (gpu_cmd::DeviceArg::Gpu, _, _) if matches!(s, Structure::Ciel(_)) => {
            bail!(
                "the GPU path takes S-CGraph and CGraph grids; this grid needs CIEL \
                 (polyhedra with more than 12 vertices): use --device cpu"
            )
        }
        (d, None, _) => d,
    };
    let gpu = pool
        .install(|| gpu_cmd::slice_gpu(device, &a.adapter, &grid, &s, &req, quiet))
        .with_context(|| format!("cannot slice {name} on the GPU"))?;
    let r = match gpu {
        Some(r) => r,
        None => pool
            .install(|| slice(&grid, &s, &req, &inc))
            .with_context(|| format!("cannot slice {name}"))?,
    };
    pb.finish_and_clear();
    let stats = stats_json(&r, &s, &grid, load_s, build_s, &name, &field);
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
    if let Some(p) = &a.stats {
        cli_write::write_json(p, &stats)?;
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

fn parse_dims(s: &str) -> Result<[usize; 3]> {
    let v: Vec<usize> = s
        .split(',')
        .map(|x| x.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--dims '{s}': expected NI,NJ,NK"))?;
    if v.len() != 3 || v.contains(&0) {
        bail!("--dims '{s}': expected three positive integers NI,NJ,NK");
    }
    if v.iter().map(|&d| (d + 1) as u128).product::<u128>() >= u32::MAX as u128 / 2 {
        bail!("--dims '{s}': too many points");
    }
    Ok([v[0], v[1], v[2]])
}

fn write_grid(path: &Path, grid: &Grid, want_ext: &str, quiet: bool) -> Result<()> {
    cli_checks::output_ext("-o", path, &[want_ext])?;
    let sp = spinner(quiet, format!("writing {}", path.display()));
    io::writers::write_vtk_xml_grid(path, grid)?;
    sp.finish_and_clear();
    if !quiet {
        eprintln!(
            "wrote {} ({} points, {} cells)",
            path.display(),
            grid.points.len(),
            grid.cell_count()
        );
    }
    Ok(())
}

fn cmd_generate(g: GenCmd, quiet: bool) -> Result<()> {
    match g {
        GenCmd::Warped { dims, seed, output } => {
            let d = parse_dims(&dims)?;
            let grid = generate::warped(d, seed);
            write_grid(&output, &grid, "vts", quiet)
        }
        GenCmd::Faulted {
            dims,
            faults,
            fault_dip,
            seed,
            output,
        } => {
            let ext = cli_checks::output_ext("-o", &output, cli_write::CORNERPOINT_EXTS)?;
            let d = parse_dims(&dims)?;
            if faults > 1000 {
                bail!("--faults must be at most 1000");
            }
            if let Some(dip) = fault_dip
                && !(generate::MIN_FAULT_DIP..=90.0).contains(&dip)
            {
                bail!(
                    "--fault-dip {dip} is outside [{}, 90] degrees",
                    generate::MIN_FAULT_DIP
                );
            }
            let g = generate::faulted_with_dip(d, faults, fault_dip, seed);
            let sp = spinner(quiet, format!("writing {}", output.display()));
            let cells = g.cell_count();
            let wrote = cli_write::write_cornerpoint(&output, &ext, g)?;
            sp.finish_and_clear();
            if !quiet {
                eprintln!(
                    "wrote {} ({cells} cells, {faults} faults)",
                    wrote.join(" and ")
                );
            }
            Ok(())
        }
        GenCmd::Zoo {
            cells,
            seed,
            output,
        } => {
            if cells == 0 || cells > 200_000_000 {
                bail!("--cells must be between 1 and 200000000");
            }
            let grid = generate::zoo(cells, seed);
            write_grid(&output, &grid, "vtu", quiet)
        }
        GenCmd::Voronoi {
            cells,
            seed,
            output,
        } => {
            if cells == 0 || cells > 50_000_000 {
                bail!("--cells must be between 1 and 50000000");
            }
            let t = Instant::now();
            let grid = stratasweep::voronoi::voronoi(cells, seed);
            if !quiet {
                eprintln!(
                    "voronoi: {cells} cells, {} vertices in {:.2} s",
                    grid.points.len(),
                    t.elapsed().as_secs_f64()
                );
            }
            write_grid(&output, &grid, "vtu", quiet)
        }
    }
}

/// One timed run: (best seconds, result of the last run).
fn timed(repeat: usize, mut f: impl FnMut() -> Result<SliceResult>) -> Result<(f64, SliceResult)> {
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..repeat.max(1) {
        let r = f()?;
        best = best.min(r.timings.sweep);
        last = Some(r);
    }
    Ok((best, last.unwrap()))
}

fn cmd_bench(a: BenchArgs, quiet: bool) -> Result<()> {
    if let Some(sizes) = &a.law {
        for &n in sizes {
            if n == 0 || n > 1024 {
                bail!("--law sizes must be in 1..=1024");
            }
        }
        return bench_law(sizes, &a, quiet, &|n| {
            Ok((generate::warped([n, n, n], 1), StructureChoice::Auto))
        });
    }
    if let Some(sizes) = &a.law_voronoi {
        if sizes.iter().any(|&n| n == 0 || n > 10_000_000) {
            bail!("--law-voronoi cell counts must be in 1..=10000000");
        }
        return bench_law(sizes, &a, quiet, &|n| {
            Ok((stratasweep::voronoi::voronoi(n, 1), StructureChoice::Ciel))
        });
    }
    if let Some(devices) = &a.device {
        return gpu_cmd::cmd_bench_devices(&a, devices, quiet);
    }
    if a.load_only {
        return bench_load(&a);
    }
    let field = parse_axis(&a.axis)?;
    cli_checks::check_count(a.count)?;
    cli_checks::check_threads(a.threads)?;
    let (grid, name, load_s, _, ijk) = load_with_info(&a.input, quiet, &Outputs::default())?;
    let t = Instant::now();
    let s = Structure::build_with(&grid, a.structure.into(), ijk.as_ref())?;
    let build_s = t.elapsed().as_secs_f64();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.max(1))
        .build()?;
    let mut req = SliceRequest {
        field: field.clone(),
        levels: LevelSpec::Count(a.count),
        attribute: None,
        threads: a.threads.max(1),
        brute_force: false,
        collect_mesh: false,
        sweep: sweep_options_from_env(),
    };
    let noop = |_: usize| {};
    let (sweep_s, sr) = timed(a.repeat, || {
        Ok(pool.install(|| slice(&grid, &s, &req, &noop))?)
    })?;
    let cut: u64 = sr.stats.iter().map(|s| s.cells).sum();
    let brute = if a.no_brute_force {
        None
    } else {
        req.brute_force = true;
        let (bs, br) = timed(1, || Ok(slice(&grid, &s, &req, &noop)?))?;
        let bcut: u64 = br.stats.iter().map(|s| s.cells).sum();
        if bcut != cut {
            bail!("brute force cut {bcut} cells but the sweep cut {cut}: this is a bug");
        }
        Some(bs)
    };
    let (mem, total) = memory_json(&s, &grid);
    let out = json!({
        "file": name, "structure": s.name(), "axis": a.axis, "count": a.count, "threads": a.threads,
        "vertices": grid.points.len(), "cells": grid.cell_count(), "cut_cells": cut, "minima": sr.minima,
        "load_s": load_s, "build_s": build_s, "field_s": sr.timings.field, "minima_s": sr.timings.minima,
        "sweep_s": sweep_s,
        "sweep_cut_cells_per_s": cut as f64 / sweep_s,
        "sweep_ns_per_cut_cell": sweep_s * 1e9 / cut as f64,
        "brute_force_s": brute,
        "brute_force_cut_cells_per_s": brute.map(|b| cut as f64 / b),
        "speedup_vs_brute_force": brute.map(|b| b / sweep_s),
        "memory_bytes": mem,
        "bytes_per_vertex": total as f64 / grid.points.len() as f64,
    });
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{name}: {} vertices, {} cells, structure {}",
            grid.points.len(),
            grid.cell_count(),
            s.name()
        );
        println!(
            "  levels {} along {}, {} cut cells, {} minima",
            a.count, a.axis, cut, sr.minima
        );
        println!(
            "  build {:.3} s, φ per vertex {:.4} s, minima {:.4} s",
            build_s, sr.timings.field, sr.timings.minima
        );
        println!(
            "  sweep       {:.4} s  {:>8.2} M cut cells/s  {:>7.1} ns/cut cell (best of {})",
            sweep_s,
            cut as f64 / sweep_s / 1e6,
            sweep_s * 1e9 / cut as f64,
            a.repeat
        );
        if let Some(b) = brute {
            println!(
                "  brute force {:.4} s  {:>8.2} M cut cells/s  sweep is {:.1}x faster",
                b,
                cut as f64 / b / 1e6,
                b / sweep_s
            );
        }
        println!(
            "  memory {:.2} B/vertex ({} B)",
            total as f64 / grid.points.len() as f64,
            total
        );
    }
    Ok(())
}

/// `bench --load-only`: GRDECL parse speed (one thread) and conversion time.
fn bench_load(a: &BenchArgs) -> Result<()> {
    let Some(path) = &a.input.grid else {
        bail!("--load-only needs a corner-point grid file")
    };
    let format = io::load::detect(path)?;
    if !format.is_cornerpoint() {
        bail!("--load-only is for corner-point input (.grdecl, .DATA, .EGRID)");
    }
    let t = Instant::now();
    let cpu0 = thread_cpu_ns();
    let (cp, bytes) = if format == io::Format::Egrid {
        let n = std::fs::metadata(path)?.len();
        (io::egrid::read_egrid(path)?.grid, n)
    } else {
        let d = io::grdecl::read_grdecl(path)?;
        (d.grid, d.bytes)
    };
    let parse_s = t.elapsed().as_secs_f64();
    let parse_cpu_s = match (cpu0, thread_cpu_ns()) {
        (Some(a), Some(b)) => Some((b - a) as f64 * 1e-9),
        _ => None,
    };
    let hwm_parse = peak_rss_bytes();
    let arrays = cp.coord.len() * 8
        + cp.zcorn.len() * 8
        + cp.actnum.as_ref().map_or(0, |x| x.len())
        + cp.properties
            .iter()
            .map(|p| p.values.len() * 8)
            .sum::<usize>();
    let cells = cp.cell_count();
    let t = Instant::now();
    let cells_dims = cp.dims;
    let (grid, rep) = cp.into_grid()?;
    let grid_s = t.elapsed().as_secs_f64();
    let out_arrays = grid_array_bytes(&grid) + rep.source_cell.len() * 4;
    let peak = peak_rss_bytes();
    let t = Instant::now();
    let s = if a.skip_build {
        None
    } else {
        let ijk = stratasweep::structures::cpgraph::IjkLayout {
            dims: cells_dims,
            source_cell: rep.source_cell.clone(),
        };
        Some(Structure::build_with(
            &grid,
            StructureChoice::Auto,
            Some(&ijk),
        )?)
    };
    let build_s = t.elapsed().as_secs_f64();
    let structure_bytes = s.as_ref().map_or(0, |s| memory_json(s, &grid).1);
    let structure = s.as_ref().map_or("none", |s| s.name());
    let nv = grid.points.len();
    let load_build_s = parse_s + grid_s + build_s;
    let out = json!({
        "file": path.display().to_string(), "bytes": bytes, "cells": cells,
        "parse_s": parse_s, "parse_mb_per_s": bytes as f64 / parse_s / 1e6,
        "array_bytes": arrays, "to_grid_s": grid_s, "output_cells": grid.cell_count(),
        "vertices": nv, "bulk_volume": rep.bulk_volume,
        "parse_cpu_s": parse_cpu_s, "parse_mb_per_cpu_s": parse_cpu_s.map(|c| bytes as f64 / c / 1e6),
        "peak_rss_after_parse": hwm_parse, "peak_rss_after_to_grid": peak,
        "grid_array_bytes": out_arrays,
        "peak_rss_over_grid_arrays": peak.map(|p| p as f64 / out_arrays as f64),
        "structure": structure, "build_s": build_s,
        "load_build_us_per_vertex": load_build_s * 1e6 / nv as f64,
        "structure_bytes_per_cell": structure_bytes as f64 / grid.cell_count() as f64,
    });
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{}: {} bytes, {} cells; parse {:.3} s = {:.1} MB/s wall (1 thread; {:.1} MB/s per CPU second), arrays {} B, peak RSS after parse {:?} B; to_grid {:.3} s -> {} cells, {} vertices, grid arrays {} B, peak RSS {:?} B",
            path.display(),
            bytes,
            cells,
            parse_s,
            bytes as f64 / parse_s / 1e6,
            parse_cpu_s.map_or(f64::NAN, |c| bytes as f64 / c / 1e6),
            arrays,
            hwm_parse,
            grid_s,
            grid.cell_count(),
            nv,
            out_arrays,
            peak
        );
        println!(
            "  build {} {:.3} s; load + build {:.3} s = {:.3} µs/vertex; structure {:.1} B/cell",
            structure,
            build_s,
            load_build_s,
            load_build_s * 1e6 / nv as f64,
            structure_bytes as f64 / grid.cell_count() as f64
        );
    }
    Ok(())
}

/// Bytes of a grid's arrays (points, cells, face streams, properties).
fn grid_array_bytes(g: &Grid) -> usize {
    let topo = match &g.topology {
        Topology::Unstructured(c) => {
            c.types.len()
                + 4 * (c.offsets.len()
                    + c.connectivity.len()
                    + c.face_offsets.len()
                    + c.face_stream.len())
        }
        Topology::Structured { .. } => 0,
    };
    g.points.len() * 24
        + topo
        + g.point_data
            .iter()
            .chain(&g.cell_data)
            .map(|p| p.values.len() * 8)
            .sum::<usize>()
}

/// CPU time of all threads of this process in ns (Linux schedstat, summed
/// over `/proc/self/task`), if available: robust to other load on the machine.
fn process_cpu_ns() -> Option<u64> {
    let mut sum = 0;
    for t in std::fs::read_dir("/proc/self/task").ok()? {
        let p = t.ok()?.path().join("schedstat");
        let s = std::fs::read_to_string(p).ok()?;
        sum += s.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(sum)
}

/// CPU time of the calling thread in ns (Linux schedstat), if available.
fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// The process's peak resident set size (Linux `VmHWM`), if available.
fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let l = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = l.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A generated grid of size `n` and the structure to sweep it with.
type LawGrid<'a> = &'a dyn Fn(usize) -> Result<(Grid, StructureChoice)>;

/// Time per level against cut cells over grid sizes, with a least-squares fit.
fn bench_law(sizes: &[usize], a: &BenchArgs, quiet: bool, make: LawGrid) -> Result<()> {
    let field = parse_axis(&a.axis)?;
    let mut rows = Vec::new();
    let mut pts: Vec<(f64, f64)> = Vec::new();
    for &n in sizes {
        let (grid, choice) = make(n)?;
        let s = Structure::build(&grid, choice)?;
        let req = SliceRequest {
            field: field.clone(),
            levels: LevelSpec::Count(a.count),
            attribute: None,
            threads: 1,
            brute_force: false,
            collect_mesh: false,
            sweep: sweep_options_from_env(),
        };
        let noop = |_: usize| {};
        let (best, r) = timed(a.repeat, || Ok(slice(&grid, &s, &req, &noop)?))?;
        let cut: u64 = r.stats.iter().map(|s| s.cells).sum();
        let per_level = best / a.count as f64;
        let cut_per_level = cut as f64 / a.count as f64;
        pts.push((cut_per_level, per_level));
        if !quiet && !a.json {
            println!(
                "  {n:>8} ({} cells, {})  {:>10.0} cut cells/level  {:>9.3} ms/level  {:>6.1} ns/cut cell",
                grid.cell_count(),
                s.name(),
                cut_per_level,
                per_level * 1e3,
                per_level * 1e9 / cut_per_level
            );
        }
        rows.push(json!({"n": n, "structure": s.name(), "cells": grid.cell_count(), "cut_cells_per_level": cut_per_level, "seconds_per_level": per_level}));
    }
    // Least squares t = a + b·cut.
    let m = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |s, p| (s.0 + p.0, s.1 + p.1));
    let (mx, my) = (sx / m, sy / m);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let syy: f64 = pts.iter().map(|p| (p.1 - my).powi(2)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let intercept = my - slope * mx;
    let r2 = if sxx > 0.0 && syy > 0.0 {
        sxy * sxy / (sxx * syy)
    } else {
        1.0
    };
    let out = json!({"rows": rows, "fit": {"seconds_per_level": "a + b * cut_cells", "a": intercept, "b_ns_per_cut_cell": slope * 1e9, "r2": r2}});
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "  fit: time/level = {:.3} us + {:.2} ns x cut cells  (R^2 = {:.5})",
            intercept * 1e6,
            slope * 1e9,
            r2
        );
    }
    Ok(())
}
