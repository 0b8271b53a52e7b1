//! `stratasweep view`: the interactive window over the library's
//! [`Scene`] (one renderer, two targets: this window and `render`'s PNG),
//! and its scripted uses (`--frames N --screenshot OUT.png`,
//! `--orbit-bench N`).

mod app;
mod overlay;
mod panel;

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde_json::json;
use winit::event_loop::EventLoop;

use stratasweep::gpu::context::GpuContext;
use stratasweep::gpu::view::scene::Scene;
use stratasweep::policy::render::Target;
use stratasweep::structures::StructureChoice;

use super::scene_args::SceneArgs;
use super::{GridArg, build_structure, load_with_info};
use app::{App, Script, Timeline};

/// `stratasweep view`.
#[derive(Args)]
pub struct ViewArgs {
    #[command(flatten)]
    input: GridArg,
    #[command(flatten)]
    scene: SceneArgs,
    /// Draw N frames, then close (with --screenshot: write the last one).
    #[arg(long)]
    frames: Option<u32>,
    /// With --frames: write the last frame's scene (without the panel) as a PNG.
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Turn the camera through N views (one full turn about the up axis), then
    /// print frame times, re-sweeps and cut cells per frame.
    #[arg(long, conflicts_with = "frames")]
    orbit_bench: Option<u32>,
    /// With --frames: write the last frame as the window shows it (scene, panel, legend).
    #[arg(long, requires = "frames")]
    window_screenshot: Option<PathBuf>,
    /// Draw only the cells of an IJK box: `I0:I1,J0:J1,K0:K1` (cell indices, end exclusive).
    #[arg(long)]
    ijk_clip: Option<String>,
    /// With --orbit-bench: print JSON.
    #[arg(long, requires = "orbit_bench")]
    json: bool,
    /// Draw the scripted frames (--frames or --orbit-bench) into an
    /// offscreen texture instead of a window: no display needed (GPU
    /// servers); frame times then leave out presenting.
    #[arg(long)]
    headless: bool,
}

/// Fails with a hint to `render` when there is no display to open a window on.
fn require_display() -> Result<()> {
    let set = |v: &str| std::env::var_os(v).is_some_and(|s| !s.is_empty());
    if !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
        bail!(
            "`view` needs a display and neither DISPLAY nor WAYLAND_DISPLAY is set; \
             use `stratasweep render ... -o out.png` for an image without a window \
             (or run under `xvfb-run -a` for a virtual display)"
        );
    }
    Ok(())
}

/// `stratasweep view`.
pub fn cmd_view(a: ViewArgs, quiet: bool) -> Result<()> {
    if a.headless && a.frames.is_none() && a.orbit_bench.is_none() {
        bail!("--headless draws a scripted run: give --frames N or --orbit-bench N");
    }
    if !a.headless {
        require_display()?;
    }
    use stratasweep::limits::check_frames;
    let flag = crate::cli::checks::flag;
    a.frames
        .map(check_frames)
        .transpose()
        .map_err(flag("--frames"))?;
    a.orbit_bench
        .map(check_frames)
        .transpose()
        .map_err(flag("--orbit-bench"))?;
    let outputs = crate::cli::checks::Outputs::default()
        .add("--screenshot", a.screenshot.as_deref())
        .add("--window-screenshot", a.window_screenshot.as_deref());
    for (flag, p) in [
        ("--screenshot", &a.screenshot),
        ("--window-screenshot", &a.window_screenshot),
    ] {
        if let Some(p) = p {
            crate::cli::checks::output_ext(flag, p, &["png"])?;
        }
    }
    let plan = a.scene.plan(Target::Window, false)?;
    let clip = a
        .ijk_clip
        .as_deref()
        .map(super::scene_args::parse_clip)
        .transpose()?;
    let (grid, name, _, _, ijk) = load_with_info(&a.input, quiet, &outputs)?;
    if let Some(c) = &clip {
        super::scene_args::check_clip(c, &grid)?;
    }
    let z_scale = super::scene_args::print_z_scale(plan.z_scale(&grid), &grid, quiet);
    // As `render`: the corner-point graph (IJK lattice) for corner-point
    // input, so the panel's pre-integration switch gets the index-space path.
    let s = build_structure(&grid, StructureChoice::Auto, ijk.as_ref(), &name, quiet)?;
    let event_loop = match a.headless {
        true => None,
        false => Some(EventLoop::new().context("cannot start the window event loop")?),
    };
    let options = crate::cli::device::context_options(&a.scene.adapter)?;
    let ctx = match &event_loop {
        Some(el) => GpuContext::with_display(|| Box::new(el.owned_display_handle()), &options)?,
        None => GpuContext::new(&options)?,
    };
    if !quiet {
        eprintln!("GPU adapter: {}", ctx.name);
    }
    // One device for the whole process: the slice worker borrows it.
    let ctx: &'static GpuContext = Box::leak(Box::new(ctx));
    let t = std::time::Instant::now();
    let scene = Scene::new(
        ctx,
        Arc::new(grid),
        Arc::new(s),
        plan.options,
        z_scale,
        plan.preintegrated,
    )?;
    if !quiet {
        eprintln!(
            "{name}: first slices in {:.3} s ({} compute dispatches)",
            t.elapsed().as_secs_f64(),
            scene.dispatches()
        );
    }
    let mut scene = scene;
    if clip.is_some() {
        scene.clip = clip;
        scene.request()?;
        scene.poll(true)?;
        if let Some(e) = scene.stats.last_error.take() {
            bail!("--ijk-clip: {e}");
        }
    }
    let script = Script {
        frames: a.frames,
        screenshot: a.screenshot.clone(),
        orbit: a.orbit_bench,
        window_shot: a.window_screenshot.clone(),
    };
    let mut app = App::new(scene, script);
    match event_loop {
        Some(el) => el
            .run_app(&mut app)
            .context("the window event loop failed")?,
        None => app.run_headless()?,
    }
    if let Some(e) = app.error.take() {
        return Err(e);
    }
    if let Some(n) = a.orbit_bench {
        // A build still running after the last view is waited for, so that
        // its duration is counted.
        app.scene.poll(true)?;
        report_bench(&app, &name, n, a.json, a.headless)?;
    } else if let (Some(p), false) = (&a.screenshot, quiet) {
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

/// The p-th percentile (nearest rank) of `v`.
fn percentile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let i = ((p / 100.0 * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1;
    s[i]
}

fn report_bench(app: &App, name: &str, n: u32, as_json: bool, headless: bool) -> Result<()> {
    let Timeline {
        frame_ms,
        cut_cells,
        stale,
    } = &app.timeline;
    let st = &app.scene.stats;
    let idle: Vec<f64> = frame_ms
        .iter()
        .zip(stale)
        .filter(|x| !*x.1)
        .map(|x| *x.0)
        .collect();
    let busy: Vec<f64> = frame_ms
        .iter()
        .zip(stale)
        .filter(|x| *x.1)
        .map(|x| *x.0)
        .collect();
    let mean_cut = cut_cells.iter().sum::<u64>() as f64 / cut_cells.len().max(1) as f64;
    let o = &app.scene.options;
    let out = json!({
        "grid": name, "views": n, "frames": frame_ms.len(),
        "frame_ms_p50": percentile(frame_ms, 50.0),
        "frame_ms_p95": percentile(frame_ms, 95.0),
        "frame_ms_max": percentile(frame_ms, 100.0),
        "idle_frames": idle.len(), "idle_frame_ms_p95": percentile(&idle, 95.0),
        "resweep_frames": busy.len(), "resweep_frame_ms_p95": percentile(&busy, 95.0),
        "resweeps": st.resweeps,
        "resweep_ms": st.resweep_ms,
        "resweep_ms_max": st.resweep_ms.iter().copied().fold(0.0, f64::max),
        "cut_cells_per_frame": mean_cut,
        "slices": o.slices, "size": [o.size.0, o.size.1], "z_scale": app.scene.z_scale,
        "compute_dispatches": app.scene.dispatches(),
        "adapter": app.scene.ctx().name,
        "headless": headless,
    });
    if as_json {
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!(
        "{name}: {} frames over one turn, {} slices, {}x{}{}; adapter {}",
        frame_ms.len(),
        o.slices,
        o.size.0,
        o.size.1,
        if headless {
            " (headless: no present)"
        } else {
            ""
        },
        app.scene.ctx().name
    );
    println!(
        "  frame ms: p50 {:.2}, p95 {:.2}, max {:.2} (idle p95 {:.2} over {} frames; during re-sweeps p95 {:.2} over {})",
        out["frame_ms_p50"].as_f64().unwrap_or(0.0),
        out["frame_ms_p95"].as_f64().unwrap_or(0.0),
        out["frame_ms_max"].as_f64().unwrap_or(0.0),
        out["idle_frame_ms_p95"].as_f64().unwrap_or(0.0),
        idle.len(),
        out["resweep_frame_ms_p95"].as_f64().unwrap_or(0.0),
        busy.len()
    );
    println!(
        "  re-sweeps {} (max {:.1} ms); {:.0} cut cells per frame",
        st.resweeps,
        out["resweep_ms_max"].as_f64().unwrap_or(0.0),
        mean_cut
    );
    Ok(())
}
