//! One criterion benchmark per stage (load, build, minima, sweep, brute
//! force), labelled by grid and output size; and the corner-point load +
//! build stages (EGRID parse, `into_grid`, convex split + CGraph) on Reek
//! when `STRATASWEEP_DATA` is set, else on a generated faulted grid.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use stratasweep::bruteforce::brute_force;
use stratasweep::extract::{EmitContext, LevelMesh};
use stratasweep::field::{AxisField, levels_by_count};
use stratasweep::generate;
use stratasweep::io::egrid::parse_egrid;
use stratasweep::io::vtk_read::parse_vtk_xml;
use stratasweep::io::writers::write_vtk_xml_grid;
use stratasweep::structures::cgraph::CGraph;
use stratasweep::structures::scgraph::SCGraph;
use stratasweep::structures::{Structure, StructureChoice};
use stratasweep::sweep::{CellGraph, Sweeper};

fn z_levels<G: CellGraph>(g: &G, k: usize) -> Vec<f32> {
    let zs = g.positions().iter().map(|p| p[2]);
    let (lo, hi) = zs.fold((f32::MAX, f32::MIN), |a, z| (a.0.min(z), a.1.max(z)));
    levels_by_count(lo as f64, hi as f64, k)
        .into_iter()
        .map(|t| t as f32)
        .collect()
}

fn cut_cells<G: CellGraph>(g: &G, levels: &[f32]) -> u64 {
    let f = AxisField {
        axis: 2,
        sign: 1.0,
        positions: g.positions(),
    };
    let ctx = EmitContext {
        positions: g.positions(),
        attribute: None,
        cells_only: false,
    };
    let mut sw = Sweeper::new(g, 1);
    sw.prepare_minima(&f, Some(4));
    sw.sweep(
        &f,
        Some(4),
        levels,
        &ctx,
        || 0u64,
        |acc, _, _, st| *acc += st.cells,
    )
    .into_iter()
    .sum()
}

fn bench_stages(c: &mut Criterion) {
    for n in [32usize, 64] {
        let grid = generate::warped([n, n, n], 1);
        let path = std::env::temp_dir().join(format!("stratasweep-bench-{n}.vts"));
        write_vtk_xml_grid(&path, &grid).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let label = format!("warped{n}^3");

        let mut g = c.benchmark_group("load");
        g.throughput(Throughput::Bytes(bytes.len() as u64));
        g.bench_function(BenchmarkId::new("vts", &label), |b| {
            b.iter(|| parse_vtk_xml(&bytes, "bench.vts").unwrap())
        });
        g.finish();

        let mut g = c.benchmark_group("build");
        g.throughput(Throughput::Elements(grid.cell_count() as u64));
        g.bench_function(BenchmarkId::new("scgraph", &label), |b| {
            b.iter(|| SCGraph::build(&grid, None).unwrap())
        });
        g.bench_function(BenchmarkId::new("cgraph", &label), |b| {
            b.iter(|| CGraph::build(&grid, None).unwrap())
        });
        g.finish();

        let s = SCGraph::build(&grid, None).unwrap();
        let f = AxisField {
            axis: 2,
            sign: 1.0,
            positions: &s.positions,
        };
        let mut g = c.benchmark_group("minima");
        g.throughput(Throughput::Elements(grid.cell_count() as u64));
        g.bench_function(BenchmarkId::new("scgraph", &label), |b| {
            b.iter(|| Sweeper::new(&s, 1).prepare_minima(&f, None))
        });
        g.finish();

        let levels = z_levels(&s, 100);
        let cut = cut_cells(&s, &levels);
        let out_label = format!("{label}/K100/{cut}cut");
        let ctx = EmitContext {
            positions: &s.positions,
            attribute: None,
            cells_only: false,
        };
        let mut g = c.benchmark_group("sweep");
        g.throughput(Throughput::Elements(cut));
        let mut sw = Sweeper::new(&s, 1);
        sw.prepare_minima(&f, Some(4));
        g.bench_function(BenchmarkId::new("scgraph", &out_label), |b| {
            b.iter(|| sw.sweep(&f, Some(4), &levels, &ctx, || (), |_, _, _, _| {}))
        });
        let cg = CGraph::build(&grid, None).unwrap();
        let fc = AxisField {
            axis: 2,
            sign: 1.0,
            positions: &cg.positions,
        };
        let ctxc = EmitContext {
            positions: &cg.positions,
            attribute: None,
            cells_only: false,
        };
        let mut swc = Sweeper::new(&cg, 1);
        swc.prepare_minima(&fc, Some(4));
        g.bench_function(BenchmarkId::new("cgraph", &out_label), |b| {
            b.iter(|| swc.sweep(&fc, Some(4), &levels, &ctxc, || (), |_, _, _, _| {}))
        });
        let mut mesh = LevelMesh::default();
        g.bench_function(BenchmarkId::new("bruteforce", &out_label), |b| {
            b.iter(|| brute_force(&s, &f, &levels, &ctx, &mut mesh, |_, _, _| {}))
        });
        g.finish();
    }
}

fn bench_cornerpoint(c: &mut Criterion) {
    let reek = std::env::var_os("STRATASWEEP_DATA")
        .map(|d| std::path::Path::new(&d).join("reek/2_R001_REEK-0.EGRID"))
        .filter(|p| p.is_file());
    let (label, bytes) = match &reek {
        Some(p) => ("reek".to_string(), std::fs::read(p).unwrap()),
        None => {
            eprintln!("STRATASWEEP_DATA not set: corner-point stages on a generated 40x64x14 grid");
            let g = generate::faulted([40, 64, 14], 3, 1);
            let mut out = Vec::new();
            use stratasweep::io::egrid::{EclData, write_array};
            let [nx, ny, nz] = g.dims;
            let head = EclData::Int(vec![1, nx as i32, ny as i32, nz as i32]);
            write_array(&mut out, "GRIDHEAD", &head).unwrap();
            let f32s = |v: &[f64]| EclData::Real(v.iter().map(|&x| x as f32).collect());
            write_array(&mut out, "COORD", &f32s(&g.coord)).unwrap();
            write_array(&mut out, "ZCORN", &f32s(&g.zcorn)).unwrap();
            if let Some(a) = &g.actnum {
                let ints = EclData::Int(a.iter().map(|&x| x as i32).collect());
                write_array(&mut out, "ACTNUM", &ints).unwrap();
            }
            ("faulted40x64x14".to_string(), out)
        }
    };
    let file = std::path::Path::new("bench.EGRID");
    let cp = parse_egrid(&bytes, file).unwrap();
    let (grid, _) = cp.clone().into_grid().unwrap();
    let mut g = c.benchmark_group("cornerpoint");
    g.bench_function(BenchmarkId::new("parse_egrid", &label), |b| {
        b.iter(|| parse_egrid(&bytes, file).unwrap())
    });
    g.bench_function(BenchmarkId::new("into_grid", &label), |b| {
        b.iter_batched(
            || cp.clone(),
            |cp| cp.into_grid().unwrap(),
            criterion::BatchSize::LargeInput,
        )
    });
    g.bench_function(BenchmarkId::new("build_cgraph", &label), |b| {
        b.iter(|| Structure::build(&grid, StructureChoice::Auto).unwrap())
    });
    g.bench_function(BenchmarkId::new("load_build", &label), |b| {
        b.iter(|| {
            let (grid, _) = parse_egrid(&bytes, file).unwrap().into_grid().unwrap();
            Structure::build(&grid, StructureChoice::Auto).unwrap()
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).warm_up_time(std::time::Duration::from_millis(500)).measurement_time(std::time::Duration::from_secs(2));
    targets = bench_stages, bench_cornerpoint
}
criterion_main!(benches);
