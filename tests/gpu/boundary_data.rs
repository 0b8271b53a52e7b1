//! The outer surface (`gpu::render::preintegrated::boundary`) of real grids from `STRATASWEEP_DATA`:
//! Reek (corner-point, faulted, 20 inactive cells) and the GEOS PEBI grid
//! (polyhedra). Closed (every directed edge matched by its reverse), and
//! its volume by the divergence theorem equals the grid's bulk volume.

use crate::support::data_dir;

use stratasweep::gpu::render::preintegrated::boundary::{Surface, outer_surface};

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(u: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

fn dot(u: [f64; 3], v: [f64; 3]) -> f64 {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

/// Volume enclosed, from the cones over the triangles from `o`.
fn volume(s: &Surface, o: [f64; 3]) -> f64 {
    s.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| sub(s.points[v as usize], o));
            dot(a, cross(b, c)) / 6.0
        })
        .sum()
}

fn area(s: &Surface) -> f64 {
    s.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| s.points[v as usize]);
            let n = cross(sub(b, a), sub(c, a));
            0.5 * dot(n, n).sqrt()
        })
        .sum()
}

/// Every directed edge is matched by as many reversed ones.
fn assert_closed(s: &Surface) {
    let mut edges = std::collections::HashMap::<(u32, u32), i64>::new();
    for t in &s.triangles {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
        }
    }
    let open = edges.values().filter(|&&n| n != 0).count();
    assert_eq!(open, 0, "{open} unbalanced edges");
}

#[test]
fn reek_is_bounded_by_its_outer_and_fault_faces() {
    let Some(data) = data_dir("reek_is_bounded_by_its_outer_and_fault_faces") else {
        return;
    };
    let deck = stratasweep::io::grdecl::read_grdecl(data.join("reek/2_R001_REEK-0.DATA")).unwrap();
    let cp = &deck.grid;
    let (grid, rep) = cp.to_grid().unwrap();
    assert_eq!(rep.inactive, 20);
    let s = outer_surface(&grid);
    assert_closed(&s);
    let v = volume(&s, grid.origin());
    let bulk = cp.bulk_volume();
    let rel = (v - bulk).abs() / bulk;
    eprintln!(
        "Reek: {} triangles, area {:.6e}, volume {v} vs bulk {bulk}: rel {rel:.2e}",
        s.triangles.len(),
        area(&s)
    );
    assert!(rel < 1e-9, "relative difference {rel}");
}

#[test]
fn the_pebi_grid_is_bounded_by_its_box() {
    let Some(data) = data_dir("the_pebi_grid_is_bounded_by_its_box") else {
        return;
    };
    let grid = stratasweep::io::load::load(&data.join("geos/pebi3d_with_properties.vtu"))
        .unwrap()
        .grid;
    let s = outer_surface(&grid);
    let (lo, hi) = grid.bounds();
    let e = [0, 1, 2].map(|a| hi[a] - lo[a]);
    let (box_v, box_a) = (
        e[0] * e[1] * e[2],
        2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0]),
    );
    let (v, a) = (volume(&s, grid.origin()), area(&s));
    eprintln!(
        "PEBI: {} triangles, volume {v} (box {box_v}), area {a} (box {box_a})",
        s.triangles.len()
    );
    assert_closed(&s);
    assert!((v - box_v).abs() < 1e-9 * box_v);
    assert!((a - box_a).abs() < 1e-9 * box_a);
}
