//! The library's limits and cancellation: a run cancelled from another
//! thread stops with `Interrupted` within a level of the request (every
//! structure's loop and the brute force), a token that is never cancelled
//! changes nothing, and levels outside the field's range come back as a
//! warning with the result.

use std::time::{Duration, Instant};

use stratasweep::cancel::Cancel;
use stratasweep::field::FieldSpec;
use stratasweep::grid::Grid;
use stratasweep::pipeline::{LevelSpec, PipelineError, SliceRequest, SliceResult, slice};
use stratasweep::structures::{Structure, StructureChoice};
use stratasweep::sweep::SweepOptions;

fn request(levels: LevelSpec, threads: usize, brute: bool, cancel: &Cancel) -> SliceRequest {
    SliceRequest {
        field: FieldSpec::Axis {
            axis: 2,
            negative: false,
        },
        levels,
        attribute: None,
        threads,
        brute_force: brute,
        collect_mesh: true,
        sweep: SweepOptions {
            cancel: cancel.clone(),
            ..Default::default()
        },
    }
}

fn run(g: &Grid, s: &Structure, req: &SliceRequest) -> Result<SliceResult, PipelineError> {
    slice(g, s, req, &|_| {})
}

/// Starts `req` on another thread, cancels it after `after`, and returns
/// the outcome with the time from the cancel to the return.
fn cancelled(
    g: &Grid,
    s: &Structure,
    req: &SliceRequest,
    cancel: &Cancel,
    after: Duration,
) -> (Result<SliceResult, PipelineError>, Duration) {
    std::thread::scope(|sc| {
        let h = sc.spawn(|| {
            let r = run(g, s, req);
            (r, Instant::now())
        });
        std::thread::sleep(after);
        let t = Instant::now();
        cancel.cancel();
        let (r, done) = h.join().unwrap();
        (r, done.saturating_duration_since(t))
    })
}

#[test]
fn a_sweep_cancelled_from_another_thread_stops_promptly() {
    // 100 000 levels of a 48³ grid: tens of seconds uncancelled.
    let g = stratasweep::generate::warped([48, 48, 48], 1);
    for (choice, threads, brute) in [
        (StructureChoice::SCGraph, 1, false),
        (StructureChoice::SCGraph, 2, false),
        (StructureChoice::CGraph, 2, false),
        (StructureChoice::SCGraph, 1, true),
    ] {
        let s = Structure::build(&g, choice).unwrap();
        let cancel = Cancel::new();
        let req = request(LevelSpec::Count(100_000), threads, brute, &cancel);
        let t = Instant::now();
        let (r, stop) = cancelled(&g, &s, &req, &cancel, Duration::from_millis(300));
        let what = format!("{choice:?}, {threads} thread(s), brute force {brute}");
        assert!(
            matches!(r, Err(PipelineError::Interrupted(_))),
            "{what}: {:?}",
            r.map(|r| r.level_values.len())
        );
        assert!(
            stop < Duration::from_secs(1),
            "{what}: stopped {stop:?} after the cancel"
        );
        assert!(t.elapsed() < Duration::from_secs(5), "{what}");
    }
}

#[test]
fn a_ciel_sweep_is_cancelled_too() {
    let g = stratasweep::voronoi::voronoi(20_000, 1);
    let s = Structure::build(&g, StructureChoice::Ciel).unwrap();
    let cancel = Cancel::new();
    let req = request(LevelSpec::Count(100_000), 2, false, &cancel);
    let (r, stop) = cancelled(&g, &s, &req, &cancel, Duration::from_millis(300));
    assert!(matches!(r, Err(PipelineError::Interrupted(_))));
    assert!(
        stop < Duration::from_secs(1),
        "stopped {stop:?} after the cancel"
    );
}

#[test]
fn a_token_cancelled_before_the_run_refuses_it_and_an_unused_one_changes_nothing() {
    let g = stratasweep::generate::warped([8, 8, 8], 1);
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let cancel = Cancel::new();
    let live = run(&g, &s, &request(LevelSpec::Count(20), 1, false, &cancel)).unwrap();
    let plain = run(
        &g,
        &s,
        &request(LevelSpec::Count(20), 1, false, &Cancel::default()),
    )
    .unwrap();
    assert_eq!(live.mesh.unwrap().positions, plain.mesh.unwrap().positions);
    cancel.cancel();
    let r = run(&g, &s, &request(LevelSpec::Count(20), 1, false, &cancel));
    assert!(matches!(r, Err(PipelineError::Interrupted(_))));
    assert_eq!(
        r.err().unwrap().to_string(),
        "the slicing run was interrupted"
    );
}

#[test]
fn depths_given_as_z_levels_come_back_with_a_warning() {
    let cp = stratasweep::generate::faulted([20, 15, 8], 2, 4);
    let (g, _) = cp.into_grid().unwrap();
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let (lo, hi) = g.bounds();
    let (top, bottom) = (-hi[2], -lo[2]); // depths
    assert!(top > 0.0, "the generated reservoir lies below z = 0");
    let depths: Vec<f64> = (0..5)
        .map(|k| top + (bottom - top) * (k as f64 + 0.5) / 5.0)
        .collect();
    let none = Cancel::default();
    let r = run(
        &g,
        &s,
        &request(LevelSpec::Values(depths.clone()), 1, false, &none),
    )
    .unwrap();
    assert_eq!(r.stats.iter().map(|s| s.polygons).sum::<u64>(), 0);
    assert_eq!(r.warnings.len(), 1, "{:?}", r.warnings);
    let w = &r.warnings[0];
    assert!(w.starts_with("all 5 levels"), "{w}");
    assert!(w.contains("outside z's range"), "{w}");
    assert!(w.contains("z is minus depth"), "{w}");
    // The levels it suggests cut the grid, with no warning.
    let neg: Vec<f64> = depths.iter().rev().map(|d| -d).collect();
    let r = run(&g, &s, &request(LevelSpec::Values(neg), 1, false, &none)).unwrap();
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    assert!(r.stats.iter().all(|s| s.polygons > 0));
}

#[test]
fn property_names_match_regardless_of_case_and_misses_suggest_a_name() {
    let g = stratasweep::generate::warped([6, 6, 6], 1);
    let name = g.point_data[0].name.clone();
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let mut req = request(LevelSpec::Count(3), 1, false, &Cancel::default());
    req.field = FieldSpec::Property(name.to_uppercase());
    let upper = run(&g, &s, &req).unwrap();
    req.field = FieldSpec::Property(name.clone());
    let exact = run(&g, &s, &req).unwrap();
    assert_eq!(upper.level_values, exact.level_values);
    req.field = FieldSpec::Property(format!("{name}x"));
    let e = run(&g, &s, &req).unwrap_err().to_string();
    assert!(e.contains(&format!("did you mean '{name}'?")), "{e}");
    // A render (its legend, its cache key) shows the grid's own spelling.
    let o = stratasweep::gpu::render::RenderOptions {
        property: Some(name.to_uppercase()),
        ..Default::default()
    };
    assert_eq!(
        stratasweep::gpu::render::shown::shown_property(&g, &o),
        Some(name.clone())
    );
}

/// The sweep behind `render` and `slice --device gpu` (`gpu::compute::tables::
/// sweep_frame`, CPU only) stops between levels too: a render's Ctrl-C
/// does not wait for its whole sweep.
#[test]
fn the_render_sweep_is_cancelled_between_levels() {
    use stratasweep::cellgraph::CellGraph;
    use stratasweep::field::AxisField;
    use stratasweep::gpu::compute::tables::sweep_frame;
    let g = stratasweep::generate::warped([48, 48, 48], 1);
    let Structure::SCGraph(s) = Structure::build(&g, StructureChoice::SCGraph).unwrap() else {
        panic!("not an S-CGraph");
    };
    let f = AxisField {
        axis: 2,
        sign: 1.0,
        positions: s.positions(),
    };
    let (lo, hi) = f
        .positions
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), p| (a.min(p[2]), b.max(p[2])));
    let k = 100_000;
    let levels: Vec<f32> = (0..k)
        .map(|i| lo + (i as f32 + 0.5) * (hi - lo) / k as f32)
        .collect();
    // Not cancelled: the same frame as with a default token, all levels.
    let few = &levels[..50];
    let a = sweep_frame(&s, &f, Some(2), few, 1, &Cancel::new()).unwrap();
    let b = sweep_frame(&s, &f, Some(2), few, 1, &Cancel::default()).unwrap();
    assert_eq!(a.0.entries.len(), b.0.entries.len());
    assert!(!a.0.entries.is_empty());
    // Cancelled from another thread after 300 ms of a sweep that takes
    // tens of seconds.
    let cancel = Cancel::new();
    let token = cancel.clone();
    let t = Instant::now();
    let stopper = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(300));
        token.cancel();
        Instant::now()
    });
    let r = sweep_frame(&s, &f, Some(2), &levels, 2, &cancel);
    let cancelled_at = stopper.join().unwrap();
    assert!(r.is_err(), "the sweep ran to its end");
    let stop = cancelled_at.elapsed();
    assert!(
        stop < Duration::from_secs(1),
        "stopped {stop:?} after the cancel"
    );
    assert!(t.elapsed() < Duration::from_secs(5));
}
