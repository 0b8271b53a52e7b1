//! `stratasweep bench`: sweep against brute force, the linear law, load speed, CPU against GPU.

use super::checks::{self as cli_checks, Outputs};
use super::common::*;
use super::device::*;
use anyhow::Result;
use anyhow::bail;
use clap::Args;
use serde_json::json;
use std::time::Instant;
use stratasweep::generate;
use stratasweep::gpu::compute::emit::GpuEmitter;
use stratasweep::gpu::compute::slice::prepare;
use stratasweep::gpu::context::GpuContext;
use stratasweep::grid::Grid;
use stratasweep::grid::Topology;
use stratasweep::io;
use stratasweep::pipeline::LevelSpec;
use stratasweep::pipeline::SliceRequest;
use stratasweep::pipeline::SliceResult;
use stratasweep::pipeline::slice;
use stratasweep::report::memory_json;
use stratasweep::structures::Structure;
use stratasweep::structures::StructureChoice;

#[derive(Args)]
pub(crate) struct BenchArgs {
    #[command(flatten)]
    pub(crate) input: GridArg,
    /// Axis to slice along.
    #[arg(long, default_value = "z", allow_hyphen_values = true)]
    pub(crate) axis: String,
    /// Number of levels.
    #[arg(long, default_value_t = 200)]
    pub(crate) count: usize,
    /// Structure for the sweep (brute force always runs on the same cells).
    #[arg(long, value_enum, default_value = "auto")]
    pub(crate) structure: StructureArg,
    /// Threads for the whole run: the load, the build and the sweep
    /// (spatial blocks in parallel).
    #[arg(long, default_value_t = 1)]
    pub(crate) threads: usize,
    /// Timed repetitions (best is reported).
    #[arg(long, default_value_t = 3)]
    pub(crate) repeat: usize,
    /// Skip the brute-force run (slow on big grids).
    #[arg(long)]
    pub(crate) no_brute_force: bool,
    /// The paper's law: time per level against cut cells over generated warped grids of these sizes (cells per axis).
    #[arg(long, value_delimiter = ',')]
    pub(crate) law: Option<Vec<usize>>,
    /// The law for CIEL: as --law over generated Voronoi grids of these cell counts (structure ciel).
    #[arg(long, value_delimiter = ',')]
    pub(crate) law_voronoi: Option<Vec<usize>>,
    /// Print JSON.
    #[arg(long)]
    pub(crate) json: bool,
    /// Compare polygon generation paths instead: cpu (1 and all threads) and/or gpu.
    #[arg(long, value_delimiter = ',')]
    pub(crate) device: Option<Vec<String>>,
    /// GPU adapter name (substring).
    #[arg(long)]
    pub(crate) adapter: Option<String>,
    /// Corner-point input only: time the parse, the conversion to a zoo
    /// grid and the build on --threads threads, then stop.
    #[arg(long)]
    pub(crate) load_only: bool,
    /// With --load-only: stop before building the sweep structure (so that
    /// `/usr/bin/time -v` measures the load alone).
    #[arg(long)]
    pub(crate) skip_build: bool,
}

/// `x / s` when finite: a run too fast for the clock (0 s) has no rate
/// (null in JSON, "n/a" in text), not "inf".
pub(crate) fn ratio(x: f64, s: f64) -> Option<f64> {
    let r = x / s;
    r.is_finite().then_some(r)
}

/// A rate for text, with `prec` decimals, or "n/a".
pub(crate) fn show(v: Option<f64>, prec: usize) -> String {
    v.map_or_else(|| "n/a".into(), |v| format!("{v:.prec$}"))
}

/// A byte count for text, or "unknown" where the system does not say.
fn bytes_or_unknown(b: Option<u64>) -> String {
    b.map_or_else(|| "unknown".into(), |b| format!("{b} B"))
}

/// One timed run: (best seconds, result of the last run).
pub(crate) fn timed(
    repeat: usize,
    mut f: impl FnMut() -> Result<SliceResult>,
) -> Result<(f64, SliceResult)> {
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..repeat.max(1) {
        let r = f()?;
        best = best.min(r.timings.sweep);
        last = Some(r);
    }
    Ok((best, last.unwrap()))
}

pub(crate) fn cmd_bench(a: BenchArgs, quiet: bool) -> Result<()> {
    stratasweep::limits::check_repeats(a.repeat).map_err(cli_checks::flag("--repeat"))?;
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
        return cmd_bench_devices(&a, devices, quiet);
    }
    cli_checks::check_threads(a.threads)?;
    // One pool for everything timed, so that "--threads 1" means one
    // thread for the load and the build too, not only for the sweep.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads)
        .build()?;
    if a.load_only {
        return pool.install(|| bench_load(&a));
    }
    let field = parse_axis(&a.axis)?;
    cli_checks::check_count(a.count)?;
    let (grid, name, load_s, _, ijk) =
        pool.install(|| load_with_info(&a.input, quiet, &Outputs::default()))?;
    let t = Instant::now();
    let s = pool.install(|| Structure::build_with(&grid, a.structure.into(), ijk.as_ref()))?;
    let build_s = t.elapsed().as_secs_f64();
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
        "sweep_cut_cells_per_s": ratio(cut as f64, sweep_s),
        "sweep_ns_per_cut_cell": ratio(sweep_s * 1e9, cut as f64),
        "brute_force_s": brute,
        "brute_force_cut_cells_per_s": brute.and_then(|b| ratio(cut as f64, b)),
        "speedup_vs_brute_force": brute.and_then(|b| ratio(b, sweep_s)),
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
            "  sweep       {:.4} s  {:>8} M cut cells/s  {:>7} ns/cut cell (best of {})",
            sweep_s,
            show(ratio(cut as f64 / 1e6, sweep_s), 2),
            show(ratio(sweep_s * 1e9, cut as f64), 1),
            a.repeat
        );
        if let Some(b) = brute {
            println!(
                "  brute force {:.4} s  {:>8} M cut cells/s  sweep is {}x faster",
                b,
                show(ratio(cut as f64 / 1e6, b), 2),
                show(ratio(b, sweep_s), 1)
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

/// `bench --load-only`: parse, conversion and build times on the current
/// rayon pool (the caller installs one of `--threads` threads).
pub(crate) fn bench_load(a: &BenchArgs) -> Result<()> {
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
    let mut stages: Vec<(&'static str, f64)> = Vec::new();
    let s = if a.skip_build {
        None
    } else {
        let ijk = stratasweep::grid::IjkLayout {
            dims: cells_dims,
            source_cell: rep.source_cell.clone(),
        };
        let mut last = Instant::now();
        let mut stage = |name: &'static str| {
            stages.push((name, last.elapsed().as_secs_f64()));
            last = Instant::now();
        };
        Some(Structure::build_cpgraph(&grid, &ijk, &mut stage)?)
    };
    let build_s = t.elapsed().as_secs_f64();
    let stage_times: serde_json::Map<_, _> = stages
        .iter()
        .map(|(k, v)| (format!("{k}_s"), json!(v)))
        .collect();
    let structure_bytes = s.as_ref().map_or(0, |s| memory_json(s, &grid).1);
    let structure = s.as_ref().map_or("none", |s| s.name());
    let nv = grid.points.len();
    let load_build_s = parse_s + grid_s + build_s;
    let out = json!({
        "file": path.display().to_string(), "bytes": bytes, "cells": cells,
        "threads": rayon::current_num_threads(),
        "parse_s": parse_s, "parse_mb_per_s": ratio(bytes as f64 / 1e6, parse_s),
        "array_bytes": arrays, "to_grid_s": grid_s, "output_cells": grid.cell_count(),
        "vertices": nv, "bulk_volume": rep.bulk_volume,
        "parse_cpu_s": parse_cpu_s, "parse_mb_per_cpu_s": parse_cpu_s.and_then(|c| ratio(bytes as f64 / 1e6, c)),
        "peak_rss_after_parse": hwm_parse, "peak_rss_after_to_grid": peak,
        "grid_array_bytes": out_arrays,
        "peak_rss_over_grid_arrays": peak.map(|p| p as f64 / out_arrays as f64),
        "structure": structure, "build_s": build_s, "build_stages": stage_times,
        "load_build_us_per_vertex": load_build_s * 1e6 / nv as f64,
        "structure_bytes_per_cell": structure_bytes as f64 / grid.cell_count() as f64,
    });
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{}: {} bytes, {} cells; parse {:.3} s = {} MB/s wall ({} thread(s); {} MB/s per CPU second of this thread), arrays {} B, peak RSS after parse {}; to_grid {:.3} s -> {} cells, {} vertices, grid arrays {} B, peak RSS {}",
            path.display(),
            bytes,
            cells,
            parse_s,
            show(ratio(bytes as f64 / 1e6, parse_s), 1),
            rayon::current_num_threads(),
            show(parse_cpu_s.and_then(|c| ratio(bytes as f64 / 1e6, c)), 1),
            arrays,
            bytes_or_unknown(hwm_parse),
            grid_s,
            grid.cell_count(),
            nv,
            out_arrays,
            bytes_or_unknown(peak)
        );
        let parts: Vec<String> = stages
            .iter()
            .map(|(k, v)| format!("{k} {v:.3} s"))
            .collect();
        println!(
            "  build {} {:.3} s ({}); load + build {:.3} s = {:.3} µs/vertex; structure {:.1} B/cell",
            structure,
            build_s,
            parts.join(", "),
            load_build_s,
            load_build_s * 1e6 / nv as f64,
            structure_bytes as f64 / grid.cell_count() as f64
        );
    }
    Ok(())
}

/// Bytes of a grid's arrays (points, cells, face streams, properties).
pub(crate) fn grid_array_bytes(g: &Grid) -> usize {
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
pub(crate) fn process_cpu_ns() -> Option<u64> {
    let mut sum = 0;
    for t in std::fs::read_dir("/proc/self/task").ok()? {
        let p = t.ok()?.path().join("schedstat");
        let s = std::fs::read_to_string(p).ok()?;
        sum += s.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(sum)
}

/// CPU time of the calling thread in ns (Linux schedstat), if available.
pub(crate) fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// The process's peak resident set size (Linux `VmHWM`), if available.
pub(crate) fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let l = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = l.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A generated grid of size `n` and the structure to sweep it with.
pub(crate) type LawGrid<'a> = &'a dyn Fn(usize) -> Result<(Grid, StructureChoice)>;

/// Time per level against cut cells over grid sizes, with a least-squares fit.
pub(crate) fn bench_law(sizes: &[usize], a: &BenchArgs, quiet: bool, make: LawGrid) -> Result<()> {
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

/// `bench --device cpu,gpu`: one row per path over the same frame.
pub(crate) fn cmd_bench_devices(a: &BenchArgs, devices: &[String], quiet: bool) -> Result<()> {
    for d in devices {
        if d != "cpu" && d != "gpu" {
            bail!("--device {d}: expected cpu and/or gpu (comma-separated)");
        }
    }
    let field = parse_axis(&a.axis)?;
    let (grid, name, _) = load(&a.input, quiet, &Outputs::default())?;
    let s = Structure::build(&grid, a.structure.into())?;
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let req = |threads: usize| SliceRequest {
        field: field.clone(),
        levels: LevelSpec::Count(a.count),
        attribute: None,
        threads,
        brute_force: false,
        collect_mesh: false,
        sweep: Default::default(),
    };
    let frame = Frame {
        grid: &grid,
        s: &s,
        req: &req,
        all,
        repeat: a.repeat.max(1),
    };
    let mut rows = Vec::new();
    let mut adapter = None;
    if devices.iter().any(|d| d == "cpu") {
        rows.extend(frame.cpu_rows()?);
    }
    if devices.iter().any(|d| d == "gpu") {
        let ctx = open(&a.adapter, quiet)?;
        adapter = Some(ctx.name.clone());
        rows.extend(frame.gpu_rows(&ctx)?);
    }
    let out = json!({"file": name, "structure": s.name(), "axis": a.axis, "count": a.count,
        "vertices": grid.points.len(), "cells": grid.cell_count(), "adapter": adapter,
        "repeat": frame.repeat, "rows": rows});
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!(
        "{name}: {} vertices, {} cells, {} levels along {}; adapter: {}",
        grid.points.len(),
        grid.cell_count(),
        a.count,
        a.axis,
        adapter.as_deref().unwrap_or("(none)")
    );
    print_device_rows(&rows);
    Ok(())
}

/// The frame that `bench --device` times on every path: the grid, its
/// structure, the request per thread count, the machine's thread count and
/// the repeats (the best is kept).
struct Frame<'a> {
    grid: &'a Grid,
    s: &'a Structure,
    req: &'a (dyn Fn(usize) -> SliceRequest + Sync),
    all: usize,
    repeat: usize,
}

impl Frame<'_> {
    /// The CPU rows: sweep and emission on 1 thread, then on all.
    fn cpu_rows(&self) -> Result<Vec<serde_json::Value>> {
        let noop = |_: usize| {};
        let mut rows = Vec::new();
        for threads in [1, self.all] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()?;
            let mut best = f64::INFINITY;
            let mut last = None;
            for _ in 0..self.repeat {
                let r = pool.install(|| slice(self.grid, self.s, &(self.req)(threads), &noop))?;
                best = best.min(r.timings.minima + r.timings.sweep);
                last = Some(r);
            }
            let r = last.expect("ran");
            let cut: u64 = r.stats.iter().map(|x| x.cells).sum();
            let tris: u64 = r.stats.iter().map(|x| x.triangles).sum();
            rows.push(
                json!({"path": format!("CPU sweep + CPU emission, {threads} thread(s)"),
                "cut_cells": cut, "triangles": tris, "ms_per_frame": best * 1e3,
                "cut_cells_per_s": ratio(cut as f64, best), "triangles_per_s": ratio(tris as f64, best)}),
            );
            if self.all == 1 {
                break;
            }
        }
        Ok(rows)
    }

    /// The GPU rows on `ctx`: CPU sweep + GPU emission, the GPU-only span
    /// space, and the GPU emission alone.
    fn gpu_rows(&self, ctx: &GpuContext) -> Result<Vec<serde_json::Value>> {
        let (all, repeat) = (self.all, self.repeat);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(all).build()?;
        let p = pool.install(|| prepare(self.grid, self.s, &(self.req)(all)))?;
        let t = Instant::now();
        let mut e = GpuEmitter::new(ctx, p.grid.clone())?;
        let grid_upload = t.elapsed().as_secs_f64();
        let mut best = (f64::INFINITY, Default::default());
        for _ in 0..repeat {
            e.run(&p.frame, false)?;
            let tm = e.timings;
            let gpu = tm.upload + tm.count + tm.emit;
            if gpu < best.0 {
                best = (gpu, tm);
            }
        }
        let (gpu_s, tm) = best;
        let cut = p.frame.entries.len() as u64;
        let tris = e.triangles as u64;
        let frame_s = p.sweep_s + gpu_s;
        let mut rows = vec![
            json!({"path": format!("CPU sweep ({all} threads) + GPU emission"),
            "cut_cells": cut, "triangles": tris, "ms_per_frame": frame_s * 1e3,
            "cut_cells_per_s": cut as f64 / frame_s, "triangles_per_s": tris as f64 / frame_s,
            "sweep_ms": p.sweep_s * 1e3, "upload_ms": tm.upload * 1e3, "count_scan_ms": tm.count * 1e3,
            "emit_ms": tm.emit * 1e3, "grid_upload_ms_once": grid_upload * 1e3}),
        ];
        let mut span = (f64::INFINITY, 0u32, 0u32);
        for _ in 0..repeat {
            let n = e.run_span(&p.frame.levels, false)?;
            let tm = e.timings;
            let secs = tm.upload + tm.count + tm.emit;
            if secs < span.0 {
                span = (secs, n, e.triangles);
            }
        }
        let (span_s, span_cut, span_tris) = span;
        rows.push(json!({"path": "GPU-only span-space (bin + count/scan + emit)",
            "cut_cells": span_cut as u64, "triangles": span_tris as u64, "ms_per_frame": span_s * 1e3,
            "cut_cells_per_s": span_cut as f64 / span_s, "triangles_per_s": span_tris as f64 / span_s}));
        rows.push(
            json!({"path": "GPU emission alone (upload + count/scan + emit)",
            "cut_cells": cut, "triangles": tris, "ms_per_frame": gpu_s * 1e3,
            "cut_cells_per_s": ratio(cut as f64, gpu_s), "triangles_per_s": ratio(tris as f64, gpu_s)}),
        );
        Ok(rows)
    }
}

/// The table of `bench --device`'s rows.
fn print_device_rows(rows: &[serde_json::Value]) {
    println!(
        "  {:<48} {:>12} {:>12} {:>14} {:>14}",
        "path", "ms/frame", "cut cells", "M cut cells/s", "M triangles/s"
    );
    for r in rows {
        println!(
            "  {:<48} {:>12.3} {:>12} {:>14} {:>14}",
            r["path"].as_str().unwrap_or(""),
            r["ms_per_frame"].as_f64().unwrap_or(0.0),
            r["cut_cells"],
            show(r["cut_cells_per_s"].as_f64().map(|v| v / 1e6), 2),
            show(r["triangles_per_s"].as_f64().map(|v| v / 1e6), 2)
        );
        if let Some(sw) = r.get("sweep_ms") {
            println!(
                "    sweep {:.3} ms (cut cells only), upload {:.3} ms, count+scan {:.3} ms, emit {:.3} ms; grid upload once {:.3} ms",
                sw.as_f64().unwrap_or(0.0),
                r["upload_ms"].as_f64().unwrap_or(0.0),
                r["count_scan_ms"].as_f64().unwrap_or(0.0),
                r["emit_ms"].as_f64().unwrap_or(0.0),
                r["grid_upload_ms_once"].as_f64().unwrap_or(0.0)
            );
        }
    }
}
