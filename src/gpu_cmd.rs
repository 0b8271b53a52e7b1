//! The GPU side of the command line: `--device` for `slice` and `bench`,
//! and the `render` command. Kept apart from `main.rs` so that the rest of
//! the CLI does not change.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};

use super::scene_args::SceneArgs;
use serde_json::json;

use stratasweep::gpu::context::{ContextOptions, GpuContext, GpuError};
use stratasweep::gpu::emit::GpuEmitter;
use stratasweep::gpu::render::{Mode, Renderer};
use stratasweep::gpu::slice::{Emitter, prepare, slice_on};
use stratasweep::grid::Grid;
use stratasweep::pipeline::{LevelSpec, SliceRequest, SliceResult, slice};
use stratasweep::structures::{Structure, StructureChoice};

use super::cli_checks::{self, Outputs};
use super::{BenchArgs, GridArg, load, parse_axis};
use stratasweep::io::guard::Named;

/// Where polygons are generated.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum DeviceArg {
    /// The CPU sweep emits the polygons.
    Cpu,
    /// The CPU sweep finds the cut cells; the GPU emits (fails without an adapter).
    Gpu,
    /// The GPU when an adapter exists, else the CPU.
    Auto,
}

/// Opens the GPU, printing the adapter's name unless quiet.
pub fn open(adapter: &Option<String>, quiet: bool) -> Result<GpuContext, GpuError> {
    let ctx = GpuContext::new(&ContextOptions {
        adapter: adapter.clone(),
        limits: None,
    })?;
    if !quiet {
        eprintln!("GPU adapter: {}", ctx.name);
    }
    Ok(ctx)
}

/// `slice --device`: `None` means "run the CPU path" (cpu, or auto without adapter).
pub fn slice_gpu(
    device: DeviceArg,
    adapter: &Option<String>,
    grid: &Grid,
    s: &Structure,
    req: &SliceRequest,
    quiet: bool,
) -> Result<Option<SliceResult>> {
    let ctx = match device {
        DeviceArg::Cpu => return Ok(None),
        DeviceArg::Gpu => open(adapter, quiet)?,
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
    let (r, t) = slice_on(Emitter::Gpu(&ctx), grid, s, req)?;
    if !quiet {
        eprintln!(
            "GPU emission: upload {:.2} ms, count+scan {:.2} ms, emit {:.2} ms",
            t.upload * 1e3,
            t.count * 1e3,
            t.emit * 1e3
        );
    }
    Ok(Some(r))
}

/// `stratasweep render`.
#[derive(Args)]
pub struct RenderArgs {
    #[command(flatten)]
    input: GridArg,
    /// Output PNG (straight RGBA).
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
    /// Draw the colour legend (property, value range) into the PNG, as the viewer shows it.
    #[arg(long)]
    legend: bool,
}

/// `stratasweep render`.
pub fn cmd_render(a: RenderArgs, quiet: bool) -> Result<()> {
    cli_checks::check_slices(a.scene.slices)?;
    let outputs = Outputs::default().add("-o", Some(&a.output));
    let transfer_file = a
        .scene
        .transfer
        .ends_with(".json")
        .then(|| Named::new("the transfer function", &a.scene.transfer));
    outputs.check_before(a.input.grid.as_deref(), transfer_file.as_slice())?;
    cli_checks::output_ext("-o", &a.output, &["png"])?;
    let o = a.scene.options()?;
    if let Some(t) = &o.transfer {
        super::render_checks::check_transfer(t)
            .with_context(|| format!("in {}", a.scene.transfer))?;
    }
    if o.mode == Mode::Iso && o.iso.is_empty() {
        bail!("--mode iso needs --iso VALUES (comma-separated)");
    }
    let (grid, name, _) = load(&a.input, quiet, &outputs)?;
    let z_scale = a.scene.z_scale(&grid, quiet);
    let s = Structure::build(&grid, StructureChoice::Auto)
        .with_context(|| format!("cannot build a structure for {name}"))?;
    let iso = if o.mode == Mode::Iso { &o.iso[..] } else { &[] };
    for v in super::render_checks::check_before(&grid, o.property.as_deref(), iso)? {
        eprintln!("warning: --iso {v} is outside the property's range: it draws nothing");
    }
    let ctx = open(&a.scene.adapter, quiet)?;
    let mut r = Renderer::new(&ctx)?;
    r.set_preintegrated(a.scene.preintegrated);
    let t = Instant::now();
    let img = r.render_exaggerated(&grid, &s, &o, z_scale)?;
    let img = if a.legend {
        crate::view::legend_onto(&ctx, &r, &grid, &o, img)?
    } else {
        img
    };
    let secs = t.elapsed().as_secs_f64();
    if super::render_checks::is_blank(&img) {
        eprintln!(
            "warning: nothing was drawn: every pixel of {} is the background (check --property, --transfer, --iso and --view-dir)",
            a.output.display()
        );
    }
    stratasweep::io::atomic::write_bytes(&a.output, &img.png()?)
        .with_context(|| format!("cannot write {}", a.output.display()))?;
    if !quiet {
        eprintln!(
            "{name}: {:?} mode, {} slices, {}x{} in {:.3} s ({} compute dispatches); wrote {}",
            a.scene.mode,
            o.slices,
            o.size.0,
            o.size.1,
            secs,
            r.dispatches(),
            a.output.display()
        );
    }
    Ok(())
}

/// `bench --device cpu,gpu`: one row per path over the same frame.
pub fn cmd_bench_devices(a: &BenchArgs, devices: &[String], quiet: bool) -> Result<()> {
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
    let noop = |_: usize| {};
    let mut rows = Vec::new();
    let mut adapter = None;
    let repeat = a.repeat.max(1);
    if devices.iter().any(|d| d == "cpu") {
        for threads in [1, all] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()?;
            let mut best = f64::INFINITY;
            let mut last = None;
            for _ in 0..repeat {
                let r = pool.install(|| slice(&grid, &s, &req(threads), &noop))?;
                best = best.min(r.timings.minima + r.timings.sweep);
                last = Some(r);
            }
            let r = last.expect("ran");
            let cut: u64 = r.stats.iter().map(|x| x.cells).sum();
            let tris: u64 = r.stats.iter().map(|x| x.triangles).sum();
            rows.push(
                json!({"path": format!("CPU sweep + CPU emission, {threads} thread(s)"),
                "cut_cells": cut, "triangles": tris, "ms_per_frame": best * 1e3,
                "cut_cells_per_s": cut as f64 / best, "triangles_per_s": tris as f64 / best}),
            );
            if all == 1 {
                break;
            }
        }
    }
    if devices.iter().any(|d| d == "gpu") {
        let ctx = open(&a.adapter, quiet)?;
        adapter = Some(ctx.name.clone());
        let pool = rayon::ThreadPoolBuilder::new().num_threads(all).build()?;
        let p = pool.install(|| prepare(&grid, &s, &req(all)))?;
        let t = Instant::now();
        let mut e = GpuEmitter::new(&ctx, p.grid.clone())?;
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
        rows.push(json!({"path": format!("CPU sweep ({all} threads) + GPU emission"),
            "cut_cells": cut, "triangles": tris, "ms_per_frame": frame_s * 1e3,
            "cut_cells_per_s": cut as f64 / frame_s, "triangles_per_s": tris as f64 / frame_s,
            "sweep_ms": p.sweep_s * 1e3, "upload_ms": tm.upload * 1e3, "count_scan_ms": tm.count * 1e3,
            "emit_ms": tm.emit * 1e3, "grid_upload_ms_once": grid_upload * 1e3}));
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
            "cut_cells_per_s": cut as f64 / gpu_s, "triangles_per_s": tris as f64 / gpu_s}),
        );
    }
    let out = json!({"file": name, "structure": s.name(), "axis": a.axis, "count": a.count,
        "vertices": grid.points.len(), "cells": grid.cell_count(), "adapter": adapter,
        "repeat": repeat, "rows": rows});
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
    println!(
        "  {:<48} {:>12} {:>12} {:>14} {:>14}",
        "path", "ms/frame", "cut cells", "M cut cells/s", "M triangles/s"
    );
    for r in &rows {
        println!(
            "  {:<48} {:>12.3} {:>12} {:>14.2} {:>14.2}",
            r["path"].as_str().unwrap_or(""),
            r["ms_per_frame"].as_f64().unwrap_or(0.0),
            r["cut_cells"],
            r["cut_cells_per_s"].as_f64().unwrap_or(0.0) / 1e6,
            r["triangles_per_s"].as_f64().unwrap_or(0.0) / 1e6
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
    Ok(())
}
