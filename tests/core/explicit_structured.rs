//! Explicit structured grids (what PyVista's `ExplicitStructuredGrid`
//! holds: one hexahedron per IJK cell, each owning its corners): the grid
//! built with its IJK layout sweeps on the corner-point graph exactly as
//! the CGraph sweeps the same grid (per level cut cells, polygons, areas,
//! and the canonical meshes bit for bit), inactive cells hidden, pinched
//! cells as polyhedra; bad arrays are refused with the cell named.

use crate::support::{assert_same, axis_request, slice_ok as run};

use std::collections::HashMap;
use stratasweep::cornerpoint::CornerPointGrid;
use stratasweep::field::FieldSpec;
use stratasweep::generate::faulted_with_dip;

use stratasweep::grid::IjkLayout;
use stratasweep::grid::{GHOST_HIDDEN_CELL, Grid, Property, Topology};
use stratasweep::io::vtk_read::{UnstructuredArrays, grid_from_explicit_structured};
use stratasweep::pipeline::{SliceRequest, SliceResult};
use stratasweep::structures::{Structure, StructureChoice};

/// Corner-point corner `q` (I + 2·J + 4·K offsets) of each VTK hexahedron corner.
const VTK_TO_CP: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// The padded arrays of `cp` as an explicit structured grid: eight points
/// per cell, hexahedra in IJK order, inactive cells hidden by `vtkGhostType`.
fn esg_arrays(cp: &CornerPointGrid) -> (Vec<[f64; 3]>, Vec<i64>, Vec<Property>) {
    let [ni, nj, nk] = cp.dims;
    let (mut points, mut cells) = (Vec::new(), Vec::new());
    let mut ghost = Vec::new();
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                let corners = cp.cell_corners(i, j, k);
                cells.push(8);
                for q in VTK_TO_CP {
                    cells.push(points.len() as i64);
                    points.push(corners[q]);
                }
                let active = cp.is_active(i + ni * (j + nj * k));
                ghost.push(if active {
                    0.0
                } else {
                    f64::from(GHOST_HIDDEN_CELL)
                });
            }
        }
    }
    let cd = vec![Property::scalar("vtkGhostType", ghost)];
    (points, cells, cd)
}

fn build(cp: &CornerPointGrid) -> (Grid, IjkLayout) {
    let (points, cells, cd) = esg_arrays(cp);
    let types = vec![12i64; cp.dims.iter().product()];
    let a = UnstructuredArrays {
        points: &points,
        cells: &cells,
        celltypes: &types,
    };
    grid_from_explicit_structured(a, cp.dims, vec![], cd, "esg").unwrap()
}

/// `auto` picks the corner-point graph, which equals the CGraph along x, y,
/// z and an oblique normal (1 and 2 threads).
fn check(cp: CornerPointGrid, what: &str) {
    let (grid, layout) = build(&cp);
    // Corner-point models have K down (left-handed IJK): the hexahedra are
    // turned right side out, so the pinched cells' polyhedra (built from
    // the hexahedron's faces) face outward, none reoriented.
    let (_, reoriented, _) = stratasweep::structures::cell_check::reoriented_polyhedra(&grid, 5);
    assert_eq!(reoriented, 0, "{what}");
    let hidden = grid.hidden_cells().unwrap();
    assert!(hidden.iter().any(|&h| h), "{what}: inactive cells hidden");
    let cg = Structure::build(&grid, StructureChoice::CGraph).unwrap();
    let auto = Structure::build_with(&grid, StructureChoice::Auto, Some(&layout)).unwrap();
    assert_eq!(auto.name(), "cpgraph", "{what}");
    assert_eq!(auto.live_cells(), cg.live_cells(), "{what}");
    // Pillar numbering: the hexahedra are coded by stencils as on the
    // GRDECL path of the same model (which welds pinched cells differently).
    let dims = cp.dims;
    let (zoo, rep) = cp.into_grid().unwrap();
    let zoo_layout = IjkLayout {
        dims,
        source_cell: rep.source_cell,
    };
    let reference = Structure::build_with(&zoo, StructureChoice::Auto, Some(&zoo_layout)).unwrap();
    let (Structure::CpGraph(ours), Structure::CpGraph(theirs)) = (&auto, &reference) else {
        panic!("{what}: not corner-point graphs");
    };
    let (c, r) = (ours.counts, theirs.counts);
    assert!(
        c.stencil_cells >= r.stencil_cells && c.stencil_cells > 0,
        "{what}: {c:?} vs GRDECL {r:?}"
    );
    assert_eq!(c.live_input_cells, r.live_input_cells, "{what}");
    let fields = [
        FieldSpec::Axis {
            axis: 2,
            negative: false,
        },
        FieldSpec::Axis {
            axis: 0,
            negative: false,
        },
        FieldSpec::Normal([0.3, -0.5, 0.8]),
    ];
    let mut cut = 0;
    for field in fields {
        let req = SliceRequest {
            field: field.clone(),
            collect_mesh: true,
            ..axis_request(0, 17)
        };
        let w = format!("{what} {field:?}");
        let want = run(&grid, &cg, &req);
        let got = run(&grid, &auto, &req);
        assert_same(&want, &got, &w);
        let two = SliceRequest {
            threads: 2,
            ..req.clone()
        };
        assert_same(&want, &run(&grid, &auto, &two), &format!("{w}, 2 threads"));
        cut += got.stats.iter().map(|s| s.cells).sum::<u64>();
    }
    assert!(cut > 0, "{what}: nothing cut");
}

#[test]
fn faulted_esg_sweeps_on_the_corner_point_graph_like_the_cgraph() {
    check(faulted_with_dip([14, 11, 9], 3, None, 1), "3 faults");
    check(faulted_with_dip([10, 12, 8], 2, Some(60.0), 5), "inclined");
}

#[test]
fn bad_explicit_arrays_are_refused() {
    let cp = faulted_with_dip([3, 2, 2], 1, None, 1);
    let (points, cells, cd) = esg_arrays(&cp);
    let mut types = vec![12i64; 12];
    fn a<'a>(points: &'a [[f64; 3]], cells: &'a [i64], types: &'a [i64]) -> UnstructuredArrays<'a> {
        UnstructuredArrays {
            points,
            cells,
            celltypes: types,
        }
    }
    let e = grid_from_explicit_structured(
        a(&points, &cells, &types),
        [3, 2, 3],
        vec![],
        cd.clone(),
        "esg",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("do not match the 12 cells"), "{e}");
    types[5] = 10;
    let e = grid_from_explicit_structured(a(&points, &cells, &types), [3, 2, 2], vec![], cd, "esg")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("esg") && e.contains("cell 5") && e.contains("hexahedra"),
        "{e}"
    );
}

/// Per (level, IJK cell), the area of a slice's polygons (world positions).
fn cell_areas(r: &SliceResult, ijk_of: &dyn Fn(usize) -> usize) -> HashMap<(u32, usize), f64> {
    let m = r.mesh.as_ref().unwrap();
    let mut out = HashMap::new();
    for p in 0..m.poly_level.len() {
        let ids = &m.poly_indices[m.poly_offsets[p] as usize..m.poly_offsets[p + 1] as usize];
        let pos: Vec<[f32; 3]> = ids.iter().map(|&i| m.positions[i as usize]).collect();
        let local: Vec<u32> = (0..ids.len() as u32).collect();
        let key = (m.poly_level[p], ijk_of(m.poly_cell[p] as usize));
        *out.entry(key).or_insert(0.0) += stratasweep::extract::polygon_area(&local, &pos);
    }
    out
}

/// The cells that are hexahedra on both paths (the explicit structured
/// grid's and the GRDECL reader's zoo grid) are cut into the same polygons:
/// per level and cell the same area (f32 positions: 1e-5).
#[test]
fn hexahedra_cut_as_on_the_grdecl_path() {
    let cp = faulted_with_dip([14, 11, 9], 3, None, 1);
    let (grid, layout) = build(&cp);
    let dims = cp.dims;
    let (zoo, rep) = cp.clone().into_grid().unwrap();
    let zoo_layout = IjkLayout {
        dims,
        source_cell: rep.source_cell,
    };
    let types = |g: &Grid| match &g.topology {
        Topology::Unstructured(c) => c.types.clone(),
        _ => unreachable!(),
    };
    let (ours, theirs) = (types(&grid), types(&zoo));
    let mut both_hex = vec![false; layout.source_cell.len()];
    for (z, &ijk) in zoo_layout.source_cell.iter().enumerate() {
        both_hex[ijk as usize] = theirs[z] == 12 && ours[ijk as usize] == 12;
    }
    let a = Structure::build_with(&grid, StructureChoice::Auto, Some(&layout)).unwrap();
    let b = Structure::build_with(&zoo, StructureChoice::Auto, Some(&zoo_layout)).unwrap();
    let req = SliceRequest {
        collect_mesh: true,
        ..axis_request(2, 23)
    };
    let ra = run(&grid, &a, &req);
    let rb = run(&zoo, &b, &req);
    assert_eq!(ra.level_values, rb.level_values);
    let ca = cell_areas(&ra, &|c| c);
    let cb = cell_areas(&rb, &|c| zoo_layout.source_cell[c] as usize);
    let mut compared = 0;
    for (key, &x) in &ca {
        if !both_hex[key.1] {
            continue;
        }
        let y = cb.get(key).copied().unwrap_or(0.0);
        assert!(
            (x - y).abs() <= 1e-5 * x.abs().max(y.abs()),
            "{key:?}: {x} vs {y}"
        );
        compared += 1;
    }
    let missing = cb
        .keys()
        .filter(|k| both_hex[k.1] && !ca.contains_key(k))
        .count();
    assert_eq!(missing, 0, "cut on the GRDECL path only");
    assert!(compared > 1000, "{compared} cells compared");
}
