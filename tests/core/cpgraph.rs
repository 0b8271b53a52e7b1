//! The corner-point graph (implicit IJK topology) against the CGraph and
//! the brute force: per level the same cut cells, polygons (the canonical
//! meshes compared for equality) and areas, on generated faulted grids
//! (many faults, inclined faults, heavy pinch-outs, inactive regions) and
//! on Reek (`STRATASWEEP_DATA`).

use crate::support;
use crate::support::{assert_same, axis_request, data_dir, slice_ok as run};

use stratasweep::cornerpoint::CornerPointGrid;
use stratasweep::field::FieldSpec;
use stratasweep::generate::{faulted, faulted_with_dip};
use stratasweep::grid::Grid;
use stratasweep::grid::IjkLayout;
use stratasweep::pipeline::{SliceRequest, SliceResult};
use stratasweep::structures::{Structure, StructureChoice};

/// The zoo grid of a corner-point grid and its IJK layout.
fn convert(cp: CornerPointGrid) -> (Grid, IjkLayout) {
    let dims = cp.dims;
    let (grid, rep) = cp.into_grid().unwrap();
    (
        grid,
        IjkLayout {
            dims,
            source_cell: rep.source_cell,
        },
    )
}

/// Heavy pinch-outs: in about a third of the layers of every column whose
/// (i + j) is not a multiple of 3, the bottom corners move up onto the top
/// ones on one or two pillars (wedges, polyhedra, zero-volume cells).
fn pinched(mut g: CornerPointGrid) -> CornerPointGrid {
    let [nx, ny, nz] = g.dims;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if (i + j) % 3 == 0 || (k * 7 + i + 2 * j) % 3 != 0 {
                    continue;
                }
                let pat = (i * 5 + j * 3 + k) % 6;
                for q in 0..4 {
                    let hit = match pat {
                        0 => q == 0,
                        1 => q == 0 || q == 1,
                        2 => q == 0 || q == 3,
                        3 => q != 2,
                        4 => true,
                        _ => q == 2,
                    };
                    if hit {
                        let (top, bot) = (g.zcorn_index(i, j, k, q), g.zcorn_index(i, j, k, q + 4));
                        g.zcorn[bot] = g.zcorn[top];
                        if k + 1 < nz {
                            // Keep the column conforming below.
                            let next = g.zcorn_index(i, j, k + 1, q);
                            g.zcorn[next] = g.zcorn[top];
                        }
                    }
                }
            }
        }
    }
    g
}

/// Inactive regions: two boxes and a scatter of single cells off.
fn with_inactive(mut g: CornerPointGrid) -> CornerPointGrid {
    let [nx, ny, nz] = g.dims;
    let mut act = g.actnum.clone().unwrap_or_else(|| vec![1; nx * ny * nz]);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let boxed = (i < nx / 3 && j < ny / 2 && k >= nz / 2)
                    || (i > nx / 2 && j > ny / 3 && k < nz / 3);
                if boxed || (i * 13 + j * 7 + k * 3) % 17 == 0 {
                    act[i + nx * (j + ny * k)] = 0;
                }
            }
        }
    }
    g.actnum = Some(act);
    g
}

/// Per level, the area of the canonical mesh's polygons (summed in mesh
/// order, so equal meshes give equal bits).
fn mesh_areas(r: &SliceResult) -> Vec<f64> {
    let m = r.mesh.as_ref().unwrap();
    let mut out = vec![0.0; r.level_values.len()];
    for p in 0..m.poly_level.len() {
        let ids = &m.poly_indices[m.poly_offsets[p] as usize..m.poly_offsets[p + 1] as usize];
        let pos: Vec<[f32; 3]> = ids.iter().map(|&i| m.positions[i as usize]).collect();
        let local: Vec<u32> = (0..ids.len() as u32).collect();
        out[m.poly_level[p] as usize] += stratasweep::extract::polygon_area(&local, &pos);
    }
    out
}

/// The corner-point graph sweeps (1 and 2 threads) and its brute force
/// equal the CGraph's sweep, along x, y, z and an oblique normal.
fn check(grid: &Grid, layout: &IjkLayout, levels: usize, what: &str) -> Structure {
    let cg = Structure::build(grid, StructureChoice::CGraph).unwrap();
    let cp = Structure::build_with(grid, StructureChoice::Auto, Some(layout)).unwrap();
    assert_eq!(
        cp.name(),
        "cpgraph",
        "{what}: auto picks the corner-point graph"
    );
    assert_eq!(cp.live_cells(), cg.live_cells(), "{what}");
    let fields = [
        FieldSpec::Axis {
            axis: 0,
            negative: false,
        },
        FieldSpec::Axis {
            axis: 1,
            negative: false,
        },
        FieldSpec::Axis {
            axis: 2,
            negative: false,
        },
        FieldSpec::Axis {
            axis: 2,
            negative: true,
        },
        FieldSpec::Normal([0.3, -0.5, 0.8]),
    ];
    let mut cut = 0;
    for field in fields {
        let req = SliceRequest {
            field: field.clone(),
            collect_mesh: true,
            ..axis_request(0, levels)
        };
        let w = format!("{what} {field:?}");
        let want = run(grid, &cg, &req);
        let got = run(grid, &cp, &req);
        assert_same(&want, &got, &w);
        assert_eq!(mesh_areas(&want), mesh_areas(&got), "{w}: areas");
        let two = run(
            grid,
            &cp,
            &SliceRequest {
                threads: 2,
                ..req.clone()
            },
        );
        assert_same(&want, &two, &format!("{w}, 2 threads"));
        let bf = run(
            grid,
            &cp,
            &SliceRequest {
                brute_force: true,
                ..req.clone()
            },
        );
        assert_same(&want, &bf, &format!("{w}, brute force"));
        cut += got.stats.iter().map(|s| s.cells).sum::<u64>();
    }
    assert!(cut > 0, "{what}: nothing cut");
    cp
}

fn counts(s: &Structure) -> stratasweep::structures::cpgraph::CpCounts {
    match s {
        Structure::CpGraph(g) => g.counts,
        _ => panic!("not a corner-point graph"),
    }
}

#[test]
fn many_faults() {
    let (grid, layout) = convert(faulted([18, 14, 9], 8, 5));
    let s = check(&grid, &layout, 37, "8 faults");
    let c = counts(&s);
    assert!(c.exception_faces > 0 && c.conforming_faces > 0, "{c:?}");
    assert_eq!(c.faces, c.conforming_faces + c.exception_faces);
    assert!(c.pieces > 0, "{c:?}");
}

#[test]
fn inclined_faults() {
    for (dip, seed) in [(50.0, 3), (70.0, 11)] {
        let (grid, layout) = convert(faulted_with_dip([16, 15, 8], 5, Some(dip), seed));
        check(&grid, &layout, 33, &format!("dip {dip}"));
    }
}

#[test]
fn heavy_pinch_outs() {
    let (grid, layout) = convert(pinched(faulted([15, 13, 10], 3, 9)));
    let s = check(&grid, &layout, 41, "pinched");
    assert!(counts(&s).explicit_cells > 100, "{:?}", counts(&s));
}

#[test]
fn inactive_regions() {
    let (grid, layout) = convert(with_inactive(faulted([17, 16, 9], 4, 2)));
    check(&grid, &layout, 35, "inactive");
}

#[test]
fn faults_add_exception_faces() {
    let (grid, layout) = convert(faulted([16, 12, 6], 0, 4));
    let none = counts(&check(&grid, &layout, 25, "no faults"));
    let (grid, layout) = convert(faulted([16, 12, 6], 4, 4));
    let four = counts(&check(&grid, &layout, 25, "4 faults"));
    assert!(
        four.exception_faces > none.exception_faces,
        "{none:?} {four:?}"
    );
}

#[test]
fn layout_must_match_the_grid() {
    let (grid, mut layout) = convert(faulted([6, 5, 4], 1, 1));
    layout.source_cell.pop();
    let e = Structure::build_with(&grid, StructureChoice::CpGraph, Some(&layout));
    assert!(e.is_err());
    let (grid, mut layout) = convert(faulted([6, 5, 4], 1, 1));
    layout.source_cell.swap(0, 1);
    assert!(Structure::build_with(&grid, StructureChoice::CpGraph, Some(&layout)).is_err());
    // Without a layout the corner-point graph cannot be built, and auto
    // keeps the CGraph.
    assert!(Structure::build_with(&grid, StructureChoice::CpGraph, None).is_err());
    assert_eq!(
        Structure::build(&grid, StructureChoice::Auto)
            .unwrap()
            .name(),
        "cgraph"
    );
}

#[test]
fn reek_equals_cgraph() {
    let Some(data) = data_dir("reek_equals_cgraph") else {
        return;
    };
    let deck = stratasweep::io::grdecl::read_grdecl(data.join("reek/2_R001_REEK-0.DATA")).unwrap();
    let (grid, layout) = convert(deck.grid);
    let s = check(&grid, &layout, 60, "Reek");
    assert!(counts(&s).exception_faces > 0);
    // The library loader gives the same layout.
    let l = stratasweep::io::load::load(&data.join("reek/2_R001_REEK-0.DATA")).unwrap();
    assert_eq!(l.ijk.as_ref(), Some(&layout));
}

/// The CLI: `info` on corner-point input reports the corner-point graph
/// with its exception faces; `--structure cpgraph` on VTK input is a clear
/// error; `bench` along z cuts the same cells with auto and cgraph.
#[test]
fn cli_picks_and_reports_the_corner_point_graph() {
    let dir = support::tmp_dir("cpgraph-cli");
    let grdecl = dir.join("f.grdecl");
    let vts = dir.join("w.vts");
    let run = |args: &[&str]| support::bin().args(args).output().unwrap();
    let g = grdecl.to_str().unwrap();
    assert!(
        run(&[
            "generate", "-q", "faulted", "--dims", "9,8,5", "--faults", "2", "-o", g
        ])
        .status
        .success()
    );
    assert!(
        run(&[
            "generate",
            "-q",
            "warped",
            "--dims",
            "4,4,4",
            "-o",
            vts.to_str().unwrap()
        ])
        .status
        .success()
    );
    let out = run(&["info", "--json", g]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["structure"], "cpgraph");
    assert!(
        j["cpgraph"]["exception_faces"].as_u64().unwrap() > 0,
        "{}",
        j["cpgraph"]
    );
    assert!(j["cpgraph"]["bytes_per_live_cell"].as_f64().unwrap() > 0.0);
    let out = run(&[
        "slice",
        "--axis",
        "z",
        "--count",
        "5",
        "--structure",
        "cpgraph",
        vts.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("corner-point"), "{err}");
    let cut = |structure: &str| {
        let args = [
            "bench",
            "--json",
            "-q",
            "--no-brute-force",
            "--repeat",
            "1",
            "--count",
            "17",
        ];
        let out = run(&[&args[..], &["--structure", structure, g]].concat());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (j["structure"].clone(), j["cut_cells"].clone())
    };
    let (a, ca) = cut("auto");
    let (b, cb) = cut("cgraph");
    assert_eq!((a.as_str(), b.as_str()), (Some("cpgraph"), Some("cgraph")));
    assert_eq!(ca, cb);
    assert!(ca.as_u64().unwrap() > 0);
    std::fs::remove_dir_all(&dir).ok();
}

/// One block's sweep output: per level, the cut cells, polygons, corners,
/// vertex bits, and the cut and visited cell counts.
type Levels = Vec<(Vec<u32>, Vec<u32>, Vec<u32>, Vec<[u32; 3]>, [u64; 2])>;

/// Sweeps `phi` over `g` with `sw` (its minima prepared for `slot`).
fn sweep_levels(
    sw: &mut stratasweep::sweep::Sweeper<stratasweep::structures::cpgraph::CpGraph>,
    g: &stratasweep::structures::cpgraph::CpGraph,
    phi: &[f32],
    slot: Option<usize>,
    levels: &[f32],
) -> Levels {
    let ctx = stratasweep::extract::EmitContext {
        positions: &g.positions,
        attribute: None,
        cells_only: false,
    };
    let f = stratasweep::field::VertexField { values: phi };
    let per_block = sw.sweep(
        &f,
        slot,
        levels,
        &ctx,
        Vec::new,
        |acc: &mut Levels, _, m, st| {
            let bits = m.positions.iter().map(|p| p.map(f32::to_bits)).collect();
            let counts = [st.cells, st.visited];
            acc.push((
                m.cells.clone(),
                m.offsets.clone(),
                m.indices.clone(),
                bits,
                counts,
            ));
        },
    );
    per_block.concat()
}

/// A neighbour's `lo` comes from the minima search when it kept the
/// field's (the same cache slot), else from decoding the neighbour: both
/// give the same levels. The minima of x are cached in slot 0, then those
/// of z in slot 2, so sweeping x again reads slot 0's minima without
/// their `lo`.
#[test]
fn neighbour_lo_kept_or_decoded() {
    let (grid, layout) = convert(faulted([14, 12, 8], 5, 9));
    let s = Structure::build_with(&grid, StructureChoice::Auto, Some(&layout)).unwrap();
    let Structure::CpGraph(g) = &s else {
        panic!("not a corner-point graph")
    };
    let g: &stratasweep::structures::cpgraph::CpGraph = g;
    let along = |a: usize| -> Vec<f32> { g.positions.iter().map(|p| p[a]).collect() };
    let (x, z) = (along(0), along(2));
    let range = |v: &[f32]| {
        let lo = v.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = v.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        (0..29)
            .map(|l| lo + (hi - lo) * (l as f32 + 0.5) / 29.0)
            .collect::<Vec<f32>>()
    };
    let (lx, lz) = (range(&x), range(&z));
    for threads in [1, 2] {
        let mut fresh = stratasweep::sweep::Sweeper::new(g, threads);
        let want = sweep_levels(&mut fresh, g, &x, None, &lx);
        let mut cached = stratasweep::sweep::Sweeper::new(g, threads);
        cached.prepare_minima(&stratasweep::field::VertexField { values: &x }, Some(0));
        cached.prepare_minima(&stratasweep::field::VertexField { values: &z }, Some(2));
        let got = sweep_levels(&mut cached, g, &x, Some(0), &lx);
        assert_eq!(want, got, "{threads} threads: x, lo decoded");
        let zs = sweep_levels(&mut cached, g, &z, Some(2), &lz);
        let mut again = stratasweep::sweep::Sweeper::new(g, threads);
        assert_eq!(zs, sweep_levels(&mut again, g, &z, None, &lz), "z, lo kept");
        assert!(want.iter().map(|l| l.0.len()).sum::<usize>() > 100);
    }
}
