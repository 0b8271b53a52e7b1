//! Unit tests of the sweep loops (generic, per-cell lattice, chunked).

use super::{LatticeSweep, Sweeper, block_minima_generic, block_minima_lattice, radix_sort_slots};
use crate::field::VertexField;
use crate::grid::{Grid, Property, Topology};
use crate::structures::scgraph::SCGraph;
use crate::sweep::CellGraph;

/// A xorshift32 generator from `seed` (non-zero).
fn xorshift(mut x: u32) -> impl FnMut() -> u32 {
    move || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        x
    }
}

/// An IJK grid of unit cubes with `n` cells per axis, about `holes` %
/// of them hidden at random; its S-CGraph, vertex counts and hidden flags.
fn unit_lattice(
    n: [usize; 3],
    holes: u32,
    rnd: &mut impl FnMut() -> u32,
) -> (SCGraph, [usize; 3], Vec<bool>) {
    let dims = [n[0] + 1, n[1] + 1, n[2] + 1];
    let np = dims.iter().product::<usize>();
    let points = (0..np)
        .map(|v| {
            let (i, j, k) = (v % dims[0], v / dims[0] % dims[1], v / (dims[0] * dims[1]));
            [i as f64, j as f64, k as f64]
        })
        .collect();
    let grid = Grid {
        points,
        topology: Topology::Structured { dims },
        point_data: vec![Property::scalar("f", vec![0.0; np])],
        cell_data: Vec::new(),
    };
    let hidden: Vec<bool> = (0..n.iter().product::<usize>())
        .map(|_| rnd() % 100 < holes)
        .collect();
    (SCGraph::build(&grid, Some(&hidden)).unwrap(), dims, hidden)
}

/// The emission context of `g` with attribute `attr`.
fn attribute_ctx<'a>(g: &'a SCGraph, attr: &'a [f32]) -> crate::extract::EmitContext<'a> {
    crate::extract::EmitContext {
        positions: g.positions(),
        attribute: Some(attr),
        cells_only: false,
    }
}

/// The lattice minima equal the generic ones (same cells, same lo, same
/// order) on random IJK grids with holes and many ties (φ in steps of
/// 0.5), with 1 to 4 blocks.
#[test]
fn lattice_minima_match_generic() {
    let mut rnd = xorshift(0x9E37_79B9_u32);
    for (n, holes) in [
        ([1, 1, 1], 0),
        ([5, 4, 3], 0),
        ([7, 6, 9], 10),
        ([12, 3, 5], 40),
    ] {
        let (g, dims, hidden) = unit_lattice(n, holes, &mut rnd);
        let np = dims.iter().product::<usize>();
        let phi: Vec<f32> = (0..np).map(|_| (rnd() % 9) as f32 * 0.5 - 2.0).collect();
        let f = VertexField { values: &phi };
        let lat = g.lattice().unwrap();
        for threads in 1..=4 {
            let sw = Sweeper::new(&g, threads);
            let mut total = 0;
            for b in &sw.blocks {
                let want = block_minima_generic(&g, &f, b).0;
                let got = block_minima_lattice(&lat, &phi, b);
                assert_eq!(got, want, "dims {dims:?} holes {holes}% threads {threads}");
                total += want.len();
            }
            assert!(
                total > 0 || hidden.iter().all(|&h| h),
                "no minima: {dims:?}"
            );
        }
    }
}

/// The lattice loops' hash-weld fallback (for layers too large for the
/// ownership window), per cell and chunked, gives the same indexed
/// meshes as the ownership weld: the same polygons as lists of grid
/// edges, one vertex per edge.
#[test]
fn lattice_hash_weld_fallback_equals_the_ownership_weld() {
    use crate::extract::EmitContext;
    let mut rnd = xorshift(0x2545_F491_u32);
    for (n, holes) in [([6, 5, 4], 0), ([7, 6, 9], 15)] {
        let (g, dims, _) = unit_lattice(n, holes, &mut rnd);
        let np = dims.iter().product::<usize>();
        let phi: Vec<f32> = (0..np).map(|_| (rnd() % 17) as f32 * 0.25 - 2.0).collect();
        let f = VertexField { values: &phi };
        let lat = g.lattice().unwrap();
        let ctx = EmitContext {
            positions: g.positions(),
            attribute: None,
            cells_only: false,
        };
        let levels: Vec<f32> = (0..15).map(|l| l as f32 * 0.25 - 1.9).collect();
        let run = |hash_weld: bool, chunked: bool| {
            let mut sw = Sweeper::new(&g, 2);
            let mut out = vec![Vec::new(); levels.len()];
            for b in &mut sw.blocks {
                let minima = super::block_minima(&g, &f, b).0;
                let on_level = |k: usize, mesh: &super::LevelMesh, _: &super::LevelStats| {
                    let mut keys = mesh.edge_keys.clone();
                    keys.sort_unstable();
                    keys.dedup();
                    assert_eq!(keys.len(), mesh.edge_keys.len(), "an edge welded twice");
                    for p in 0..mesh.polygon_count() {
                        let ids =
                            &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
                        let corners: Vec<u64> =
                            ids.iter().map(|&i| mesh.edge_keys[i as usize]).collect();
                        out[k].push((mesh.cells[p], corners));
                    }
                };
                let input = LatticeSweep {
                    lat,
                    phi: &phi,
                    ctx: &ctx,
                    hash_weld,
                };
                if chunked {
                    super::chunks::sweep_block_chunks(&input, b, &minima, &levels, on_level);
                } else {
                    super::sweep_block_lattice(&input, b, &minima, &levels, on_level);
                }
            }
            for l in &mut out {
                l.sort();
            }
            out
        };
        let owned = run(false, false);
        assert!(owned.iter().map(Vec::len).sum::<usize>() > 0, "nothing cut");
        for chunked in [false, true] {
            assert_eq!(
                run(true, chunked),
                owned,
                "dims {dims:?} holes {holes}% chunked {chunked}"
            );
        }
    }
}

/// The batched, unchecked writes of the lattice emitter
/// (`lattice::emit::HexWriter`) give, level by level, the hash-welded path's
/// output: the same polygons in the same order, each corner with the
/// same grid edge, position bits and attribute bits, and running sums
/// (area, triangles, cut cells) equal to the ones recomputed from the
/// mesh. Levels cut more cells than one batch (1024), and a noisy φ
/// puts cells with ambiguous faces (which end a batch) among them.
#[test]
fn batched_emission_equals_the_hash_weld() {
    let mut rnd = xorshift(0x68E3_1DA4_u32);
    let (g, dims, _) = unit_lattice([50, 44, 5], 3, &mut rnd);
    let np = dims.iter().product::<usize>();
    // Layers of φ near k, with noise that makes faces ambiguous.
    let phi: Vec<f32> = (0..np)
        .map(|v| (v / (dims[0] * dims[1])) as f32 + (rnd() % 64) as f32 / 80.0 - 0.4)
        .collect();
    let attr: Vec<f32> = (0..np).map(|_| (rnd() % 1000) as f32 * 0.001).collect();
    let f = VertexField { values: &phi };
    let lat = g.lattice().unwrap();
    let ctx = attribute_ctx(&g, &attr);
    let levels: Vec<f32> = (0..9).map(|l| l as f32 * 0.55 + 0.2).collect();
    // Per level: the polygons (cell, corners as edge key, position and
    // attribute bits), cut cells and the running sums.
    type Corner = (u64, [u32; 3], u32);
    type Level = (Vec<(u32, Vec<Corner>)>, u32, u64, usize);
    let run = |hash_weld: bool| -> Vec<Level> {
        let mut sw = Sweeper::new(&g, 1);
        let mut out = vec![Default::default(); levels.len()];
        let b = &mut sw.blocks[0];
        let minima = super::block_minima(&g, &f, b).0;
        let on_level = |k: usize, mesh: &super::LevelMesh, _: &super::LevelStats| {
            let polys = (0..mesh.polygon_count())
                .map(|p| {
                    let ids = &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
                    let corners = ids
                        .iter()
                        .map(|&i| {
                            let i = i as usize;
                            (
                                mesh.edge_keys[i],
                                mesh.positions[i].map(f32::to_bits),
                                mesh.values[i].to_bits(),
                            )
                        })
                        .collect();
                    (mesh.cells[p], corners)
                })
                .collect();
            assert_eq!(mesh.accumulated_area().to_bits(), mesh.area().to_bits());
            assert_eq!(mesh.accumulated_triangles(), mesh.triangle_count());
            out[k] = (
                polys,
                mesh.cut_cells,
                mesh.accumulated_area().to_bits(),
                mesh.accumulated_triangles(),
            );
        };
        let input = LatticeSweep {
            lat,
            phi: &phi,
            ctx: &ctx,
            hash_weld,
        };
        super::chunks::sweep_block_chunks(&input, b, &minima, &levels, on_level);
        out
    };
    let batched = run(false);
    assert!(
        batched.iter().any(|l| l.1 > 1024),
        "no level fills a batch: {:?}",
        batched.iter().map(|l| l.1).collect::<Vec<_>>()
    );
    // Cells with a face whose corners alternate above and below.
    let faces = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    let [_, dj, dk] = lat.deltas;
    let ambiguous: usize = batched
        .iter()
        .zip(&levels)
        .map(|(l, &t)| {
            let mut cells: Vec<u32> = l.0.iter().map(|p| p.0).collect();
            cells.dedup();
            cells
                .iter()
                .filter(|&&c| {
                    let f = unsafe { super::lattice::load8(&phi, c - lat.base, dj, dk) };
                    faces.iter().any(|q| {
                        let a = q.map(|v| f[v] >= t);
                        a[0] == a[2] && a[1] == a[3] && a[0] != a[1]
                    })
                })
                .count()
        })
        .sum();
    assert!(
        ambiguous > 10,
        "only {ambiguous} cells with an ambiguous face"
    );
    assert_eq!(run(true), batched);
}

/// The chunked lattice loop gives, level by level, the same output as
/// the per-cell loop: the same cut cells in the same order, the same
/// indexed polygons, areas and visited counts. Random IJK grids with
/// holes, φ in steps that put many vertices exactly on levels, 1 to 3
/// blocks, and rows shorter and longer than a chunk.
#[test]
fn chunked_loop_equals_the_cell_loop() {
    let mut rnd = xorshift(0x6A09_E667_u32);
    // Ramps along ±i, ±j and ±k (φ from -2 to 2 across the grid) make
    // the sweep cross chunk ends along i, rows and layers, both ways, as
    // its only way on.
    for (n, holes, (axis, ramp)) in [
        ([1, 1, 1], 0, (0, 0.0)),
        ([6, 5, 4], 0, (0, 0.0)),
        ([7, 6, 9], 15, (0, 0.0)),
        ([70, 3, 4], 10, (0, 0.0)),
        ([130, 2, 3], 0, (0, 0.0)),
        ([9, 8, 7], 60, (0, 0.0)),
        ([200, 1, 1], 0, (0, -1.0)),
        ([200, 1, 1], 0, (0, 1.0)),
        ([150, 2, 1], 5, (0, -1.0)),
        ([70, 40, 1], 0, (1, -1.0)),
        ([300, 12, 1], 0, (1, -1.0)),
        ([300, 12, 1], 0, (1, 1.0)),
        ([150, 1, 12], 0, (2, -1.0)),
        ([150, 1, 12], 3, (2, 1.0)),
        ([300, 12, 2], 35, (1, -1.0)),
        ([300, 12, 2], 35, (1, 1.0)),
        ([150, 2, 12], 35, (2, -1.0)),
        ([150, 2, 12], 35, (2, 1.0)),
        // Several patch rows and columns of every width.
        ([20, 37, 5], 0, (1, -1.0)),
        ([21, 35, 5], 10, (2, 1.0)),
        ([70, 19, 3], 5, (0, 1.0)),
        ([13, 70, 2], 0, (0, -1.0)),
    ] {
        let (g, dims, _) = unit_lattice(n, holes, &mut rnd);
        let np = dims.iter().product::<usize>();
        let phi: Vec<f32> = (0..np)
            .map(|v| {
                let ijk = [v % dims[0], v / dims[0] % dims[1], v / (dims[0] * dims[1])];
                if ramp == 0.0 {
                    (rnd() % 17) as f32 * 0.25 - 2.0
                } else {
                    ramp * (ijk[axis] as f32 / dims[axis] as f32 * 4.0 - 2.0)
                }
            })
            .collect();
        let attr: Vec<f32> = (0..np).map(|_| (rnd() % 1000) as f32 * 0.01).collect();
        let f = VertexField { values: &phi };
        let lat = g.lattice().unwrap();
        let ctx = attribute_ctx(&g, &attr);
        // Levels on and between the φ steps, some outside the range;
        // evenly spaced and not.
        let even: Vec<f32> = (0..23).map(|l| l as f32 * 0.25 - 2.6).collect();
        let uneven: Vec<f32> = (0..12).map(|l| (l * l) as f32 * 0.04 - 2.1).collect();
        for (levels, threads) in [(&even, 1), (&even, 2), (&even, 3), (&uneven, 2)] {
            let run = |width: Option<u32>| {
                let mut sw = Sweeper::new(&g, threads);
                let mut out = Vec::new();
                for b in &mut sw.blocks {
                    let minima = super::block_minima(&g, &f, b).0;
                    let mut on_level =
                        |k: usize, mesh: &super::LevelMesh, st: &super::LevelStats| {
                            out.push((
                                k,
                                mesh.cells.clone(),
                                mesh.offsets.clone(),
                                mesh.indices.clone(),
                                mesh.edge_keys.clone(),
                                mesh.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                                st.visited,
                                st.area.to_bits(),
                            ));
                        };
                    let input = LatticeSweep {
                        lat,
                        phi: &phi,
                        ctx: &ctx,
                        hash_weld: false,
                    };
                    match width {
                        Some(w) => super::chunks::sweep_block_patches(
                            w,
                            &input,
                            b,
                            &minima,
                            levels,
                            &mut on_level,
                        ),
                        None => {
                            super::sweep_block_lattice(&input, b, &minima, levels, &mut on_level)
                        }
                    }
                }
                out
            };
            let cells = run(None);
            assert!(
                cells.iter().map(|o| o.1.len()).sum::<usize>() > 0 || holes > 50,
                "nothing cut: {dims:?}"
            );
            for width in super::chunks::WIDTHS {
                assert_eq!(
                    run(Some(width)),
                    cells,
                    "dims {dims:?} holes {holes}% threads {threads} patch width {width}"
                );
            }
        }
    }
}

/// One sweeper reused for many sweeps (different level counts, fields
/// and directions, on the lattice and the generic loop) cuts the same
/// cells as a fresh sweeper every time: stamps of an earlier sweep
/// (steps and swept-out marks) never hide a cell from a later one.
#[test]
fn a_reused_sweeper_cuts_what_a_fresh_one_cuts() {
    use crate::extract::EmitContext;
    use crate::field::ScalarField;
    /// φ per vertex without the array: takes the generic loop.
    struct Opaque<'a>(&'a [f32]);
    impl ScalarField for Opaque<'_> {
        fn phi(&self, v: u32) -> f32 {
            self.0[v as usize]
        }
    }
    let mut rnd = xorshift(0x1234_5679_u32);
    let (g, dims, _) = unit_lattice([6, 7, 5], 10, &mut rnd);
    let np = dims.iter().product::<usize>();
    let ctx = EmitContext {
        positions: g.positions(),
        attribute: None,
        cells_only: true,
    };
    let cells = |sw: &mut Sweeper<SCGraph>, phi: &[f32], generic: bool, levels: &[f32]| {
        let mut out = if generic {
            let f = Opaque(phi);
            sw.prepare_minima(&f, None);
            sw.sweep(&f, None, levels, &ctx, Vec::new, |acc, k, m, _| {
                acc.extend(m.cells.iter().map(|&c| (k, c)))
            })
        } else {
            let f = VertexField { values: phi };
            sw.prepare_minima(&f, None);
            sw.sweep(&f, None, levels, &ctx, Vec::new, |acc, k, m, _| {
                acc.extend(m.cells.iter().map(|&c| (k, c)))
            })
        }
        .concat();
        out.sort_unstable();
        out
    };
    for threads in [1, 2] {
        let mut reused = Sweeper::new(&g, threads);
        for round in 0..12 {
            let phi: Vec<f32> = (0..np).map(|_| (rnd() % 64) as f32 * 0.125).collect();
            let n = 1 + (rnd() % 40) as usize;
            // The first level lies above many cells' lo, so that step
            // pushes cells that the last sweep swept out.
            let first = 0.5 + (rnd() % 32) as f32 * 0.125;
            let levels: Vec<f32> = (0..n).map(|l| first + l as f32 * 4.0 / n as f32).collect();
            let generic = round % 3 == 2;
            let want = cells(&mut Sweeper::new(&g, threads), &phi, generic, &levels);
            assert!(!want.is_empty());
            let got = cells(&mut reused, &phi, generic, &levels);
            if got != want {
                let missed: Vec<_> = want.iter().filter(|c| !got.contains(c)).take(5).collect();
                panic!(
                    "threads {threads} round {round}: {} cut cells, want {}; missed (level, cell) {missed:?}",
                    got.len(),
                    want.len()
                );
            }
        }
    }
}

/// The radix sort against the standard sort: empty, one element,
/// duplicates, keys spanning 1, 2 and 3 digits, and a non-zero start.
#[test]
fn radix_sort_matches_std_sort() {
    let mut scratch = Vec::new();
    let mut rnd = xorshift(0x2545_f491);
    for (n, len, start) in [
        (0usize, 10u32, 0u32),
        (1, 10, 5),
        (100, 7, 3),
        (5000, 2000, 100),
        (5000, 3_000_000, 17),
        (20000, 4_000_000_000, 1),
    ] {
        let mut v: Vec<u32> = (0..n).map(|_| start + rnd() % len).collect();
        let mut want = v.clone();
        want.sort_unstable();
        radix_sort_slots(&mut v, &mut scratch, start, len);
        assert_eq!(v, want, "n={n} len={len} start={start}");
    }
}
