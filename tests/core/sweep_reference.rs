//! The sweep structures against the brute-force reference on random grids:
//! holes, several components, values exactly on levels, axis slices exactly
//! on vertex layers; plus watertightness of isosurfaces.

use crate::support::{Levels, Rng, cells_of, sorted, structured, zoo_from_structured};
use std::collections::HashMap;
use stratasweep::bruteforce::brute_force;
use stratasweep::extract::{EmitContext, LevelMesh};
use stratasweep::field::{PlaneField, ScalarField, VertexField, materialise};
use stratasweep::grid::Grid;
use stratasweep::structures::cgraph::CGraph;
use stratasweep::structures::scgraph::SCGraph;
use stratasweep::sweep::{CellGraph, Sweeper};

/// Per level: sorted (source cell, polygon positions) list.
fn collect(mesh: &LevelMesh, g: &impl CellGraph, out: &mut Vec<(u32, Vec<[f32; 3]>)>) {
    for p in 0..mesh.polygon_count() {
        let ids = &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
        out.push((
            g.source_cell(mesh.cells[p]),
            ids.iter().map(|&i| mesh.positions[i as usize]).collect(),
        ));
    }
}

/// Sweeps `levels` over `threads` blocks with `attribute` interpolated, and
/// gathers per level what `gather` takes from each block's mesh.
fn sweep_levels<G: CellGraph, F: ScalarField, T: Send + Clone>(
    g: &G,
    f: &F,
    axis: Option<usize>,
    levels: &[f32],
    threads: usize,
    attribute: Option<&[f32]>,
    gather: impl Fn(&mut Vec<T>, usize, &LevelMesh) + Sync,
) -> Vec<Vec<T>> {
    let ctx = EmitContext {
        positions: g.positions(),
        attribute,
        cells_only: false,
    };
    let mut sw = Sweeper::new(g, threads);
    sw.prepare_minima(f, axis);
    let parts = sw.sweep(
        f,
        axis,
        levels,
        &ctx,
        || vec![Vec::new(); levels.len()],
        |acc: &mut Vec<Vec<T>>, k, mesh, st| {
            assert_eq!(st.polygons as usize, mesh.polygon_count());
            gather(&mut acc[k], k, mesh);
        },
    );
    let mut all = vec![Vec::new(); levels.len()];
    for p in parts {
        for (k, v) in p.into_iter().enumerate() {
            all[k].extend(v);
        }
    }
    all
}

fn run_sweep<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    axis: Option<usize>,
    levels: &[f32],
    threads: usize,
) -> Levels {
    sorted(sweep_levels(
        g,
        f,
        axis,
        levels,
        threads,
        None,
        |out, _, mesh| collect(mesh, g, out),
    ))
}

fn run_brute<G: CellGraph, F: ScalarField>(g: &G, f: &F, levels: &[f32]) -> Levels {
    let ctx = EmitContext {
        positions: g.positions(),
        attribute: None,
        cells_only: false,
    };
    let mut all = vec![Vec::new(); levels.len()];
    let mut mesh = LevelMesh::default();
    brute_force(g, f, levels, &ctx, &mut mesh, |k, m, _| {
        collect(m, g, &mut all[k])
    });
    sorted(all)
}

fn check_equal(a: &Levels, b: &Levels, what: &str) {
    assert_eq!(cells_of(a), cells_of(b), "{what}: cell sets differ");
    assert_eq!(a, b, "{what}: polygons differ");
}

/// Every field to test on a grid: six axis directions with integer levels
/// (exactly on vertex layers), a general normal, and the property.
fn check_all_fields<G: CellGraph>(g: &G, origin: [f64; 3], values: &[f32], label: &str) {
    let pos = g.positions();
    for axis in 0..3 {
        for neg in [false, true] {
            let mut n = [0.0f32; 3];
            n[axis] = if neg { -1.0 } else { 1.0 };
            let f = PlaneField {
                normal: n,
                positions: pos,
            };
            // World integer layers -> local values.
            let o = (origin[axis] * n[axis] as f64) as f32;
            let levels: Vec<f32> = (-12..=12).map(|x| x as f32 - o).collect();
            let want = run_brute(g, &f, &levels);
            assert!(
                want.iter().map(Vec::len).sum::<usize>() > 0,
                "{label}: nothing cut"
            );
            // φ materialised per vertex (as the pipeline does) takes the
            // S-CGraph's specialised lattice loop; it must give the same
            // output as the generic loop and the brute force.
            let phi = materialise(&f, pos.len());
            let fv = VertexField { values: &phi };
            for threads in [1, 3] {
                let got = run_sweep(g, &f, Some(axis * 2 + neg as usize), &levels, threads);
                check_equal(
                    &got,
                    &want,
                    &format!("{label} axis {axis} neg {neg} threads {threads}"),
                );
                let got = run_sweep(g, &fv, Some(axis * 2 + neg as usize), &levels, threads);
                check_equal(
                    &got,
                    &want,
                    &format!("{label} axis {axis} neg {neg} threads {threads} materialised"),
                );
            }
            // Second sweep reuses the cached minima.
            let mut sw = Sweeper::new(g, 1);
            sw.prepare_minima(&f, Some(axis * 2));
        }
    }
    let f = PlaneField {
        normal: [0.48, -0.6, 0.64],
        positions: pos,
    };
    let levels: Vec<f32> = (0..37).map(|x| -9.0 + x as f32 * 0.5).collect();
    let want = run_brute(g, &f, &levels);
    check_equal(
        &run_sweep(g, &f, None, &levels, 1),
        &want,
        &format!("{label} normal"),
    );
    let phi = materialise(&f, pos.len());
    check_equal(
        &run_sweep(g, &VertexField { values: &phi }, None, &levels, 1),
        &want,
        &format!("{label} normal materialised"),
    );
    let f = VertexField { values };
    let levels: Vec<f32> = (0..9).map(|x| x as f32 * 0.5).collect();
    let want = run_brute(g, &f, &levels);
    for threads in [1, 2] {
        check_equal(
            &run_sweep(g, &f, None, &levels, threads),
            &want,
            &format!("{label} property threads {threads}"),
        );
    }
}

fn f32_values(g: &Grid) -> Vec<f32> {
    g.point_data[0].values.iter().map(|&v| v as f32).collect()
}

#[test]
fn scgraph_and_cgraph_match_brute_force_on_random_structured_grids() {
    let mut rng = Rng(7);
    for case in 0..6 {
        let n = [2 + rng.below(6), 2 + rng.below(6), 2 + rng.below(6)];
        let jitter = if case % 2 == 0 { 0.0 } else { 0.3 };
        let g = structured(n, jitter, if case < 2 { 0.0 } else { 0.25 }, &mut rng);
        let hidden = g.hidden_cells();
        let vals = f32_values(&g);
        let s = SCGraph::build(&g, hidden.as_deref()).unwrap();
        check_all_fields(&s, s.origin, &vals, &format!("scgraph case {case} {n:?}"));
        let c = CGraph::build(&g, hidden.as_deref()).unwrap();
        check_all_fields(
            &c,
            c.origin,
            &vals,
            &format!("cgraph(structured) case {case} {n:?}"),
        );
    }
}

/// φ range over live cells by a scan of every cell (the reference).
fn scan_range<G: CellGraph, F: ScalarField>(g: &G, f: &F) -> Option<(f32, f32)> {
    let mut ids = [0u32; stratasweep::metacell::MAX_META_VERTICES];
    let mut r: Option<(f32, f32)> = None;
    for s in (0..g.slot_count() as u32).filter(|&s| g.is_live(s)) {
        let (_, n) = g.cell(s, &mut ids);
        for &v in &ids[..n] {
            let p = f.phi(v);
            r = Some(r.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
        }
    }
    r
}

/// `phi_range_if_all_live` on the S-CGraph: the scanned range when every
/// cell is live (planes and the property, materialised or not), `None`
/// when some cell is hidden.
#[test]
fn scgraph_phi_range_without_a_scan_equals_the_scan() {
    let mut rng = Rng(19);
    for case in 0..6 {
        let n = [1 + rng.below(6), 1 + rng.below(6), 1 + rng.below(6)];
        let holes = if case < 4 { 0.0 } else { 0.3 };
        let g = structured(n, 0.3, holes, &mut rng);
        let hidden = g.hidden_cells();
        let s = SCGraph::build(&g, hidden.as_deref()).unwrap();
        let vals = f32_values(&g);
        let plane = PlaneField {
            normal: [0.48, -0.6, 0.64],
            positions: &s.positions,
        };
        let phi = materialise(&plane, s.positions.len());
        let label = format!("case {case} {n:?}");
        let all_live = hidden.is_none_or(|h| h.iter().all(|&x| !x));
        let want = scan_range(&s, &plane);
        let fast = [
            s.phi_range_if_all_live(&plane),
            s.phi_range_if_all_live(&VertexField { values: &phi }),
        ];
        for got in fast {
            assert_eq!(got, if all_live { want } else { None }, "{label} plane");
        }
        let prop = VertexField { values: &vals };
        let got = s.phi_range_if_all_live(&prop);
        let want = scan_range(&s, &prop);
        assert_eq!(got, if all_live { want } else { None }, "{label} property");
        assert!(want.is_some(), "{label}: no live cell");
    }
}

#[test]
fn cgraph_matches_brute_force_on_random_zoo_grids() {
    let mut rng = Rng(11);
    for case in 0..5 {
        let n = [2 + rng.below(5), 2 + rng.below(5), 2 + rng.below(5)];
        let s = structured(n, if case % 2 == 0 { 0.0 } else { 0.25 }, 0.0, &mut rng);
        let g = zoo_from_structured(&s, &mut rng);
        let vals = f32_values(&g);
        let c = CGraph::build(&g, None).unwrap();
        assert_eq!(
            c.class_counts[1..],
            [0, 0, 0, 0, 0],
            "generated zoo cells must be valid"
        );
        check_all_fields(&c, c.origin, &vals, &format!("zoo case {case} {n:?}"));
    }
}

/// Checks that every welded edge is used by exactly two polygons, once in
/// each direction (closed, consistently oriented 2-manifold).
fn assert_closed_manifold(mesh: &LevelMesh, label: &str) {
    let mut uses: HashMap<(u32, u32), i32> = HashMap::new();
    for p in 0..mesh.polygon_count() {
        let ids = &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
        for i in 0..ids.len() {
            let (a, b) = (ids[i], ids[(i + 1) % ids.len()]);
            assert_ne!(a, b, "{label}: polygon repeats a welded vertex");
            *uses.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
        }
    }
    let mut count: HashMap<(u32, u32), u32> = HashMap::new();
    for p in 0..mesh.polygon_count() {
        let ids = &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
        for i in 0..ids.len() {
            let (a, b) = (ids[i], ids[(i + 1) % ids.len()]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    for (e, n) in &count {
        assert_eq!(*n, 2, "{label}: edge {e:?} used by {n} polygons");
        assert_eq!(
            uses[e], 0,
            "{label}: edge {e:?} used twice in the same direction"
        );
    }
}

#[test]
fn isosurfaces_inside_the_domain_are_closed_manifolds() {
    let mut rng = Rng(99);
    let mut ambiguous_hits = 0;
    for case in 0..8 {
        let n = [4 + rng.below(5), 4 + rng.below(5), 4 + rng.below(5)];
        let mut g = structured(n, 0.2, 0.0, &mut rng);
        // Interior vertices: noisy values (continuous and quantised);
        // boundary vertices: below every level, so the surfaces are closed.
        let Some(stratasweep::grid::Topology::Structured { dims }) = Some(g.topology.clone())
        else {
            unreachable!()
        };
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let v = i + dims[0] * (j + dims[1] * k);
                    let border = i == 0
                        || j == 0
                        || k == 0
                        || i + 1 == dims[0]
                        || j + 1 == dims[1]
                        || k + 1 == dims[2];
                    g.point_data[0].values[v] = if border {
                        -1.0
                    } else if case % 2 == 0 {
                        rng.f64() * 4.0
                    } else {
                        (rng.f64() * 8.0).floor() * 0.5
                    };
                }
            }
        }
        let grids: Vec<(String, Grid)> = vec![
            ("hex".to_string(), g.clone()),
            ("zoo".to_string(), zoo_from_structured(&g, &mut rng)),
        ];
        for (label, grid) in grids {
            let vals = f32_values(&grid);
            let c = CGraph::build(&grid, None).unwrap();
            let f = VertexField { values: &vals };
            let levels: Vec<f32> = (1..8)
                .map(|x| x as f32 * 0.5 + 0.013 * (case % 2) as f32)
                .collect();
            sweep_levels(
                &c,
                &f,
                None,
                &levels,
                1,
                None,
                |_: &mut Vec<()>, k, mesh| {
                    assert_closed_manifold(mesh, &format!("{label} case {case} level {k}"));
                },
            );
            if label == "hex" {
                // The S-CGraph's lattice loop welds by edge ownership instead
                // of the hash map: its isosurfaces must be closed as well.
                let s = SCGraph::build(&grid, None).unwrap();
                sweep_levels(
                    &s,
                    &f,
                    None,
                    &levels,
                    1,
                    None,
                    |_: &mut Vec<()>, k, mesh| {
                        assert_closed_manifold(mesh, &format!("scgraph case {case} level {k}"));
                    },
                );
            }
            // Count ambiguous configurations met, so the test proves it exercised them.
            let mut ids = [0u32; 12];
            for cell in 0..c.slot_count() as u32 {
                let (m, nv) = c.cell(cell, &mut ids);
                let meta = c.catalog().get(m);
                for &t in &levels {
                    let phi: Vec<f32> = ids[..nv].iter().map(|&v| vals[v as usize]).collect();
                    let code = stratasweep::extract::code_of(&phi, t);
                    ambiguous_hits += meta.config_is_ambiguous(code) as usize;
                }
            }
        }
    }
    assert!(
        ambiguous_hits > 100,
        "only {ambiguous_hits} ambiguous configurations were exercised"
    );
}

/// φ per vertex without exposing the array, so the sweep takes its generic
/// loop (hash-map weld) even on the S-CGraph.
struct Opaque<'a>(&'a [f32]);

impl ScalarField for Opaque<'_> {
    fn phi(&self, v: u32) -> f32 {
        self.0[v as usize]
    }
}

/// Per level: (cell, its corners as (grid edge key, attribute bits)).
type WeldedLevels = Vec<Vec<(u32, Vec<(u64, u32)>)>>;

/// Per level: sorted (cell, corner edge keys) of every block's polygons,
/// after checking that each block's mesh has one vertex per edge key.
fn welded<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    attribute: &[f32],
    levels: &[f32],
    threads: usize,
) -> WeldedLevels {
    let mut all = sweep_levels(
        g,
        f,
        None,
        levels,
        threads,
        Some(attribute),
        |out, k, mesh| {
            let mut keys = mesh.edge_keys.clone();
            keys.sort_unstable();
            keys.dedup();
            assert_eq!(
                keys.len(),
                mesh.edge_keys.len(),
                "level {k}: an edge welded twice"
            );
            assert_eq!(mesh.positions.len(), mesh.edge_keys.len());
            // The running area equals the polygons' areas recomputed from
            // the welded mesh, bit for bit (same corners, same order).
            let area: f64 = (0..mesh.polygon_count())
                .map(|p| {
                    let ids = &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
                    stratasweep::extract::polygon_area(ids, &mesh.positions)
                })
                .sum();
            assert_eq!(mesh.area().to_bits(), area.to_bits(), "level {k}: area");
            for p in 0..mesh.polygon_count() {
                let ids = &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
                let corners = ids.iter().map(|&i| {
                    (
                        mesh.edge_keys[i as usize],
                        mesh.values[i as usize].to_bits(),
                    )
                });
                out.push((mesh.cells[p], corners.collect()));
            }
        },
    );
    for l in &mut all {
        l.sort();
    }
    all
}

/// The lattice loop's ownership weld gives the same indexed meshes as the
/// generic loop's hash weld: the same polygons as lists of grid edges and
/// one vertex per cut edge with the same interpolated attribute bits, on
/// random IJK grids with holes, in one block
/// and in several (block borders cut ownership chains).
#[test]
fn lattice_weld_matches_the_hash_weld() {
    let mut rng = Rng(21);
    for case in 0..8 {
        let n = [2 + rng.below(7), 2 + rng.below(7), 2 + rng.below(7)];
        let g = structured(n, 0.3, if case < 2 { 0.0 } else { 0.3 }, &mut rng);
        let hidden = g.hidden_cells();
        let vals = f32_values(&g);
        let s = SCGraph::build(&g, hidden.as_deref()).unwrap();
        let levels: Vec<f32> = (0..9).map(|x| x as f32 * 0.5).collect();
        for threads in [1, 2, 3] {
            // The attribute (a second field, here φ's square) is
            // interpolated onto the vertices the same way on both paths.
            let attr: Vec<f32> = vals.iter().map(|v| v * v).collect();
            let lattice = welded(&s, &VertexField { values: &vals }, &attr, &levels, threads);
            let generic = welded(&s, &Opaque(&vals), &attr, &levels, threads);
            assert!(
                lattice.iter().map(Vec::len).sum::<usize>() > 0,
                "case {case}: nothing cut"
            );
            assert_eq!(lattice, generic, "case {case} {n:?} threads {threads}");
        }
    }
}
