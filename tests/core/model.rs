//! Grid-model behaviour: degenerate and inverted cells, hidden cells,
//! cell-to-vertex averaging, precision far from the origin.

use stratasweep::field::FieldSpec;
use stratasweep::grid::{Cells, Grid, Property, Topology, hex_corner_offsets, vtk_type};
use stratasweep::pipeline::{LevelSpec, SliceRequest, SliceResult, slice, vertex_property};
use stratasweep::structures::CellClass;
use stratasweep::structures::cgraph::CGraph;
use stratasweep::structures::{Structure, StructureChoice};

/// Two unit hexes side by side along x (x in [0,2]), plus extra cells.
fn two_hexes(extra: impl FnOnce(&mut Vec<[f64; 3]>, &mut Cells)) -> Grid {
    let mut points = Vec::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..3 {
                points.push([i as f64, j as f64, k as f64]);
            }
        }
    }
    let v = |i: u32, j: u32, k: u32| i + 3 * j + 6 * k;
    let mut cells = Cells::default();
    for i in 0..2 {
        cells.push(
            vtk_type::HEXAHEDRON,
            &[
                v(i, 0, 0),
                v(i + 1, 0, 0),
                v(i + 1, 1, 0),
                v(i, 1, 0),
                v(i, 0, 1),
                v(i + 1, 0, 1),
                v(i + 1, 1, 1),
                v(i, 1, 1),
            ],
        );
    }
    extra(&mut points, &mut cells);
    Grid {
        points,
        topology: Topology::Unstructured(cells),
        point_data: vec![],
        cell_data: vec![],
    }
}

fn request(field: FieldSpec, levels: LevelSpec) -> SliceRequest {
    SliceRequest {
        field,
        levels,
        attribute: None,
        threads: 1,
        brute_force: false,
        collect_mesh: true,
        sweep: Default::default(),
    }
}

/// Slices `g` along +z at `levels` with the automatic structure.
fn slice_z(g: &Grid, levels: LevelSpec) -> SliceResult {
    let s = Structure::build(g, StructureChoice::Auto).unwrap();
    let field = FieldSpec::Axis {
        axis: 2,
        negative: false,
    };
    slice(g, &s, &request(field, levels), &|_| {}).unwrap()
}

#[test]
fn degenerate_cells_are_reported_and_skipped_without_nan() {
    let g = two_hexes(|points, cells| {
        // A flat hex (zero volume) and a tet with a repeated vertex.
        let base = points.len() as u32;
        for p in [
            [0.0, 0.0, 5.0],
            [1.0, 0.0, 5.0],
            [1.0, 1.0, 5.0],
            [0.0, 1.0, 5.0],
        ] {
            points.push(p);
        }
        cells.push(
            vtk_type::HEXAHEDRON,
            &[
                base,
                base + 1,
                base + 2,
                base + 3,
                base,
                base + 1,
                base + 2,
                base + 3,
            ],
        );
        points.push([0.5, 0.5, 5.0]);
        cells.push(vtk_type::TETRA, &[base, base + 1, base + 2, base + 4]);
        // An inverted (mirrored) tet.
        let t = points.len() as u32;
        for p in [
            [5.0, 0.0, 0.0],
            [6.0, 0.0, 0.0],
            [5.0, 1.0, 0.0],
            [5.0, 0.0, 1.0],
        ] {
            points.push(p);
        }
        cells.push(vtk_type::TETRA, &[t, t + 2, t + 1, t + 3]);
    });
    let c = CGraph::build(&g, None).unwrap();
    assert_eq!(c.class_counts[CellClass::Valid as usize], 2);
    assert_eq!(c.class_counts[CellClass::RepeatedVertex as usize], 1);
    assert_eq!(c.class_counts[CellClass::ZeroVolume as usize], 1);
    assert_eq!(c.class_counts[CellClass::Inverted as usize], 1);
    assert_eq!(
        c.live_cells(),
        3,
        "valid and inverted cells are swept, degenerate ones are not"
    );
    let r = slice_z(&g, LevelSpec::Count(20));
    let m = r.mesh.unwrap();
    assert!(m.positions.iter().flatten().all(|v| v.is_finite()));
    assert!(m.values.iter().all(|v| v.is_finite()));
    assert!(
        !m.poly_cell.contains(&2) && !m.poly_cell.contains(&3),
        "degenerate cells produced polygons"
    );
    // z = 0.5-ish slices through the two unit hexes: area 2 each (plus the tet).
    assert!(r.stats.iter().any(|s| s.cells >= 2));
}

#[test]
fn hidden_cells_are_excluded() {
    let mut g = two_hexes(|_, _| {});
    g.cell_data
        .push(Property::scalar("vtkGhostType", vec![0.0, 32.0]));
    let r = slice_z(&g, LevelSpec::Values(vec![0.5]));
    assert_eq!(r.stats[0].cells, 1);
    assert!((r.stats[0].area - 1.0).abs() < 1e-6, "{}", r.stats[0].area);
    // Ghost bit other than 32 (duplicate cell) keeps the cell.
    g.cell_data[0].values[1] = 1.0;
    let r = slice_z(&g, LevelSpec::Values(vec![0.5]));
    assert_eq!(r.stats[0].cells, 2);
    assert!((r.stats[0].area - 2.0).abs() < 1e-6);
}

#[test]
fn cell_properties_average_to_vertices_by_volume() {
    // Hex 0 is stretched to twice the volume of hex 1 (x in [0,2] and [2,3]).
    let mut g = two_hexes(|_, _| {});
    for p in &mut g.points {
        p[0] = match p[0] as i32 {
            0 => 0.0,
            1 => 2.0,
            _ => 3.0,
        };
    }
    g.cell_data.push(Property::scalar("PORO", vec![0.1, 0.4]));
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let v = vertex_property(&g, &s, "PORO").unwrap();
    // Vertices of only cell 0, shared, only cell 1.
    assert!((v[0] - 0.1).abs() < 1e-6);
    assert!(
        (v[1] - (2.0 * 0.1 + 1.0 * 0.4) / 3.0).abs() < 1e-6,
        "{}",
        v[1]
    );
    assert!((v[2] - 0.4).abs() < 1e-6);
    assert!(vertex_property(&g, &s, "NOPE").is_err());
}

#[test]
fn utm_coordinates_keep_sub_millimetre_precision() {
    let mut g = two_hexes(|_, _| {});
    let off = [461_234.567, 5_934_567.891, -1_712.345];
    for p in &mut g.points {
        for a in 0..3 {
            p[a] += off[a];
        }
    }
    let z = off[2] + 0.25;
    let r = slice_z(&g, LevelSpec::Values(vec![z]));
    let m = r.mesh.unwrap();
    assert!((r.level_values[0] - z).abs() < 1e-9);
    let mut xs: Vec<f64> = (0..m.positions.len())
        .map(|v| m.world_position(v)[0] - off[0])
        .collect();
    xs.sort_by(f64::total_cmp);
    for v in 0..m.positions.len() {
        let w = m.world_position(v);
        assert!((w[2] - z).abs() < 1e-4, "z {} vs {z}", w[2]);
    }
    assert!((xs[0] - 0.0).abs() < 1e-4 && (xs[xs.len() - 1] - 2.0).abs() < 1e-4);
    assert!((r.stats[0].area - 2.0).abs() < 1e-5);
}

#[test]
fn constant_fields_and_empty_grids_are_errors() {
    let g = two_hexes(|_, _| {});
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let mut g2 = g.clone();
    g2.point_data
        .push(Property::scalar("c", vec![1.0; g.points.len()]));
    let e = slice(
        &g2,
        &s,
        &request(FieldSpec::Property("c".into()), LevelSpec::Count(3)),
        &|_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("constant"), "{e}");
    let empty = Grid {
        points: vec![],
        topology: Topology::Unstructured(Cells::default()),
        point_data: vec![],
        cell_data: vec![],
    };
    assert!(Structure::build(&empty, StructureChoice::Auto).is_err());
    let e = slice(
        &g,
        &s,
        &request(
            FieldSpec::Axis {
                axis: 0,
                negative: false,
            },
            LevelSpec::Values(vec![1.0, 0.5]),
        ),
        &|_| {},
    );
    assert!(e.is_err());
}

/// The stencil-coded CGraph returns exactly the input cells and symmetric
/// neighbours, whether a cell's stencil is common (IJK-ordered block) or
/// escaped (cells shuffled out of order), and a hexahedral grid stays
/// within the 40 bytes per cell budget (plus 16 per vertex).
#[test]
fn stencil_coded_cgraph_decodes_exactly_and_fits_the_budget() {
    let s = stratasweep::generate::warped([12, 10, 9], 5);
    let Topology::Structured { dims } = s.topology else {
        panic!("warped is structured")
    };
    let [npi, npj, npk] = dims;
    let slab = npi * npj;
    let mut hexes: Vec<[u32; 8]> = Vec::new();
    for k in 0..npk - 1 {
        for j in 0..npj - 1 {
            for i in 0..npi - 1 {
                let v0 = i + j * npi + k * slab;
                hexes.push(hex_corner_offsets(npi, slab).map(|o| (v0 + o) as u32));
            }
        }
    }
    let build = |order: &[usize]| {
        let mut cells = Cells::default();
        for &c in order {
            cells.push(vtk_type::HEXAHEDRON, &hexes[c]);
        }
        let grid = Grid {
            topology: Topology::Unstructured(cells.clone()),
            ..s.clone()
        };
        (CGraph::build(&grid, None).unwrap(), cells)
    };
    let part = |g: &CGraph, k: &str| g.bytes().iter().find(|b| b.0 == k).map_or(0, |b| b.1);
    // Move every 7th cell to the end: those (and their neighbours) get odd
    // stencils and are stored explicitly.
    let (mut order, tail): (Vec<usize>, Vec<usize>) = (0..hexes.len()).partition(|c| c % 7 != 0);
    order.extend(tail);
    let (g, cells) = build(&order);
    assert!(part(&g, "cell_stencil_ids") > 0 && part(&g, "explicit_cells") > 0);
    use stratasweep::sweep::CellGraph;
    let none = stratasweep::structures::cgraph::NONE;
    let mut ids = [0u32; 12];
    for c in 0..cells.len() {
        let (_, n) = g.cell(c as u32, &mut ids);
        assert_eq!(&ids[..n], cells.cell(c), "cell {c}");
        let nb = g.neighbours(c as u32);
        assert_eq!(nb.len(), 6);
        for &n in nb.iter().filter(|&&n| n != none) {
            assert!(
                g.neighbours(n).contains(&(c as u32)),
                "{c} -> {n} not mutual"
            );
        }
        let interior = nb.iter().filter(|&&n| n != none).count();
        assert!(interior >= 3, "cell {c} has only {interior} neighbours");
    }
    // In IJK order nearly every cell shares a stencil.
    let (g, _) = build(&(0..hexes.len()).collect::<Vec<_>>());
    let cell_bytes: usize = g
        .bytes()
        .iter()
        .filter(|b| b.0 != "positions")
        .map(|b| b.1)
        .sum::<usize>()
        + 2 * g.cell_count(); // u16 step stamps
    let per_cell = cell_bytes as f64 / g.cell_count() as f64;
    assert!(per_cell <= 40.0, "{per_cell} B/cell");
    assert_eq!(part(&g, "positions"), 12 * s.points.len());
}
