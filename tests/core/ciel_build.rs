//! CIEL build against independent references: bad polyhedra are errors
//! naming the cell and the face, and the CIEL's arrays equal a
//! straightforward rebuild from the input faces (hash maps, no sorting
//! tricks), also with scrambled face orders and dead cells.

use crate::support::{Rng, cube_faces, cube_points, one_cell, polyhedral};
use stratasweep::grid::{Cells, Grid, Topology, vtk_type};
use stratasweep::structures::ciel::{Ciel, CielError, parse_face_stream};

#[test]
fn bad_polyhedra_are_errors_naming_cell_and_face() {
    let ok = Ciel::build(&one_cell(&cube_faces(), cube_points()), None).unwrap();
    assert_eq!(ok.half_edge_count(), 24);
    assert_eq!(ok.counts.flipped_faces, 0);
    // Open: a face missing.
    let mut f = cube_faces();
    f.pop();
    let e = Ciel::build(&one_cell(&f, cube_points()), None).unwrap_err();
    assert!(matches!(e, CielError::Open { cell: 0, .. }), "{e}");
    assert!(e.to_string().contains("cell 0, face"), "{e}");
    // Short face.
    let mut f = cube_faces();
    f.push(vec![0, 1]);
    let e = Ciel::build(&one_cell(&f, cube_points()), None).unwrap_err();
    assert_eq!(
        e,
        CielError::ShortFace {
            cell: 0,
            face: 6,
            len: 2
        }
    );
    // Duplicate face (reversed copy).
    let mut f = cube_faces();
    f.push(f[2].iter().rev().copied().collect());
    let e = Ciel::build(&one_cell(&f, cube_points()), None).unwrap_err();
    assert_eq!(
        e,
        CielError::DuplicateFace {
            cell: 0,
            face: 2,
            other: 6
        }
    );
    // Non-manifold: an extra triangle on an existing edge.
    let mut f = cube_faces();
    f.push(vec![0, 1, 7]);
    let e = Ciel::build(&one_cell(&f, cube_points()), None).unwrap_err();
    assert!(
        matches!(
            e,
            CielError::NonManifoldEdge { cell: 0, .. } | CielError::Open { cell: 0, .. }
        ),
        "{e}"
    );
    // Repeated vertex inside a face.
    let mut f = cube_faces();
    f[0] = vec![0, 2, 0, 1];
    let e = Ciel::build(&one_cell(&f, cube_points()), None).unwrap_err();
    assert!(
        matches!(
            e,
            CielError::RepeatedFaceVertex {
                cell: 0,
                face: 0,
                ..
            }
        ),
        "{e}"
    );
    // Inconsistent input orientation is fixed (outward) and counted.
    let mut f = cube_faces();
    f[1].reverse();
    f[3].reverse();
    let c = Ciel::build(&one_cell(&f, cube_points()), None).unwrap();
    assert_eq!(c.counts.flipped_faces, 2);
    // Everything reversed: the volume sign turns all faces outward.
    let f: Vec<Vec<u32>> = cube_faces()
        .into_iter()
        .map(|mut x| {
            x.reverse();
            x
        })
        .collect();
    let c = Ciel::build(&one_cell(&f, cube_points()), None).unwrap();
    assert_eq!(c.counts.flipped_faces, 6);
    // A face shared by three cells.
    let mut pts = cube_points();
    pts.push([0.5, 0.5, -1.0]);
    pts.push([0.5, 0.5, -2.0]);
    let mut cells = Cells::default();
    cells.push_polyhedron(&cube_faces());
    let pyr = |apex: u32| {
        vec![
            vec![0, 2, 3, 1],
            vec![0, 1, apex],
            vec![1, 3, apex],
            vec![3, 2, apex],
            vec![2, 0, apex],
        ]
    };
    cells.push_polyhedron(&pyr(8));
    cells.push_polyhedron(&pyr(9));
    let g = Grid {
        points: pts,
        topology: Topology::Unstructured(cells),
        point_data: vec![],
        cell_data: vec![],
    };
    let e = Ciel::build(&g, None).unwrap_err();
    assert!(e.to_string().contains("shared by 3 cells"), "{e}");
    // A Möbius-like non-orientable face set cannot be oriented: a cube whose
    // top face is given twisted is caught as open/non-manifold or orientation.
    let mut f = cube_faces();
    f[1] = vec![4, 5, 6, 7];
    let e = Ciel::build(&one_cell(&f, cube_points()), None).unwrap_err();
    assert!(e.to_string().contains("cell 0"), "{e}");
}

/// `g` with every polyhedron's faces randomly reversed and rotated (the
/// build must orient them; face 0 inward reverses the whole cell), and a
/// dead hexahedron (one vertex eight times) before every `dead_every`-th
/// cell.
fn scramble_faces(g: &Grid, rng: &mut Rng, dead_every: usize) -> Grid {
    let Topology::Unstructured(cells) = &g.topology else {
        panic!("unstructured grid expected")
    };
    let mut out = Cells::default();
    for c in 0..cells.len() {
        if c % dead_every == dead_every / 2 {
            out.push(vtk_type::HEXAHEDRON, &[c as u32; 8]);
        }
        if cells.types[c] != vtk_type::POLYHEDRON {
            out.push(cells.types[c], cells.cell(c));
            continue;
        }
        let mut faces = parse_face_stream(c, cells.faces_of(c)).unwrap();
        for f in faces.iter_mut() {
            if rng.f64() < 0.4 {
                f.reverse();
            }
            let r = rng.below(f.len());
            f.rotate_left(r);
        }
        out.push_polyhedron(&faces);
    }
    Grid {
        points: g.points.clone(),
        topology: Topology::Unstructured(out),
        point_data: g.point_data.clone(),
        cell_data: g.cell_data.clone(),
    }
}

/// Newell normal of loop `f` dotted with (face centroid − `centre`):
/// positive for an outward face of a star-shaped cell.
fn outwardness(points: &[[f64; 3]], f: &[u32], centre: [f64; 3]) -> f64 {
    let mut nrm = [0.0; 3];
    let mut fc = [0.0; 3];
    for (i, &v) in f.iter().enumerate() {
        let a = points[v as usize];
        let b = points[f[(i + 1) % f.len()] as usize];
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
        for k in 0..3 {
            fc[k] += a[k] / f.len() as f64;
        }
    }
    (0..3).map(|k| nrm[k] * (fc[k] - centre[k])).sum()
}

/// The CIEL of `g` field by field against a straightforward rebuild from
/// the input faces alone (hash maps, no sorting tricks): cell ranges,
/// origins with their face flags (outward loops; the cell's face order
/// reversed when its first input face points inward), `mate_face`,
/// `mate_cell` (faces with equal vertex sets in two cells), the vertex
/// cycles (smallest half-edge of each fan, per origin in id order), the
/// cell lookup and the counts. Typed cells keep the catalog's loops, which
/// are checked to be the cell's faces, outward.
fn check_against_reference_build(g: &Grid, c: &Ciel, label: &str) {
    use stratasweep::structures::ciel::{FIRST_IN_FACE, LAST_IN_FACE, NONE};
    let Topology::Unstructured(cells) = &g.topology else {
        panic!("unstructured grid expected")
    };
    let hidden = g.hidden_cells();
    let p = &g.points;
    let mut words: Vec<u32> = Vec::new();
    let mut cell_start = vec![0u32];
    let mut faces: Vec<(u32, std::ops::Range<u32>)> = Vec::new();
    let (mut flipped, mut n_hidden) = (0usize, 0usize);
    for ci in 0..cells.len() {
        if hidden.as_ref().is_some_and(|h| h[ci]) {
            n_hidden += 1;
            cell_start.push(words.len() as u32);
            continue;
        }
        let (loops, f) = reference_loops(g, c, ci, label);
        flipped += f;
        for f in &loops {
            let s = words.len() as u32;
            for (i, &v) in f.iter().enumerate() {
                let mut w = v;
                if i == 0 {
                    w |= FIRST_IN_FACE;
                }
                if i + 1 == f.len() {
                    w |= LAST_IN_FACE;
                }
                words.push(w);
            }
            faces.push((ci as u32, s..words.len() as u32));
        }
        cell_start.push(words.len() as u32);
    }
    let n = words.len();
    assert_eq!(c.cell_start, cell_start, "{label}: cell_start");
    assert_eq!(c.half_edge_count(), n, "{label}: half-edges");
    let org = |h: usize| words[h] & stratasweep::structures::ciel::VERTEX_MASK;
    let mut next = vec![0usize; n];
    let mut cell_of = vec![0u32; n];
    for (cell, r) in &faces {
        for h in r.clone() {
            next[h as usize] = if h + 1 == r.end { r.start } else { h + 1 } as usize;
            cell_of[h as usize] = *cell;
        }
    }
    let (mate_face, mate_cell) = reference_mates(&cell_start, &faces, &next, org, label);
    let is_rep = reference_reps(&mate_face, &mate_cell);
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); p.len()];
    for h in (0..n).filter(|&h| is_rep[h]) {
        around[org(h) as usize].push(h as u32);
    }
    for h in 0..n {
        let hh = h as u32;
        assert_eq!(c.origin_word(hh), words[h], "{label}: origin of {h}");
        assert_eq!(c.mate_face(hh), mate_face[h], "{label}: mate_face of {h}");
        assert_eq!(c.mate_cell(hh), mate_cell[h], "{label}: mate_cell of {h}");
        assert_eq!(c.cell_of(hh), cell_of[h], "{label}: cell of {h}");
    }
    for (v, want) in around.iter().enumerate() {
        assert_eq!(c.around_vertex(v as u32), &want[..], "{label}: vertex {v}");
    }
    let reps = is_rep.iter().filter(|&&x| x).count();
    assert_eq!(c.counts.faces, faces.len(), "{label}: faces");
    assert_eq!(c.counts.flipped_faces, flipped, "{label}: flipped faces");
    assert_eq!(c.counts.hidden, n_hidden, "{label}: hidden");
    assert_eq!(c.counts.edges, reps / 2, "{label}: edges");
    assert_eq!(
        c.counts.border_half_edges,
        mate_cell.iter().filter(|&&m| m == NONE).count(),
        "{label}: border"
    );
}

/// The reference's outward loops of cell `ci` (see
/// [`check_against_reference_build`]) and how many of its input faces
/// pointed inward.
fn reference_loops(g: &Grid, c: &Ciel, ci: usize, label: &str) -> (Vec<Vec<u32>>, usize) {
    let Topology::Unstructured(cells) = &g.topology else {
        panic!("unstructured grid expected")
    };
    let p = &g.points;
    let mut flipped = 0;
    let loops = if cells.types[ci] == vtk_type::POLYHEDRON {
        let input = parse_face_stream(ci, cells.faces_of(ci)).unwrap();
        let mut verts: Vec<u32> = input.concat();
        verts.sort_unstable();
        verts.dedup();
        let mut centre = [0.0; 3];
        for &v in &verts {
            for k in 0..3 {
                centre[k] += p[v as usize][k] / verts.len() as f64;
            }
        }
        let inward: Vec<bool> = input
            .iter()
            .map(|f| outwardness(p, f, centre) < 0.0)
            .collect();
        flipped += inward.iter().filter(|&&x| x).count();
        let mut out: Vec<Vec<u32>> = input
            .iter()
            .zip(&inward)
            .map(|(f, &i)| {
                let mut f = f.clone();
                if i {
                    f.reverse();
                }
                f
            })
            .collect();
        if inward[0] {
            out.reverse();
        }
        out
    } else if cells.cell(ci).iter().all(|&v| v == cells.cell(ci)[0]) {
        // A dead cell (one vertex eight times): no half-edges.
        Vec::new()
    } else {
        assert_eq!(cells.types[ci], vtk_type::HEXAHEDRON, "{label}");
        let ids = cells.cell(ci);
        let built = c.faces_of(ci as u32);
        let set = |f: &[u32]| {
            let mut s = f.to_vec();
            s.sort_unstable();
            s
        };
        let mut want: Vec<Vec<u32>> = [
            [0, 1, 2, 3],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [1, 2, 6, 5],
            [2, 3, 7, 6],
            [3, 0, 4, 7],
        ]
        .iter()
        .map(|f| set(&f.map(|l| ids[l])))
        .collect();
        let mut got: Vec<Vec<u32>> = built.iter().map(|f| set(f)).collect();
        want.sort();
        got.sort();
        assert_eq!(got, want, "{label}: cell {ci}'s faces");
        let mut centre = [0.0; 3];
        for &v in ids {
            for k in 0..3 {
                centre[k] += p[v as usize][k] / 8.0;
            }
        }
        for f in &built {
            assert!(outwardness(p, f, centre) > 0.0, "{label}: cell {ci} inward");
        }
        built
    };
    (loops, flipped)
}

/// The reference's `mate_face` (the opposite directed edge in the same
/// cell) and `mate_cell` (faces with the same vertex set in two cells,
/// reversed) of half-edges `0..next.len()`.
fn reference_mates(
    cell_start: &[u32],
    faces: &[(u32, std::ops::Range<u32>)],
    next: &[usize],
    org: impl Fn(usize) -> u32,
    label: &str,
) -> (Vec<u32>, Vec<u32>) {
    use std::collections::HashMap;
    use stratasweep::structures::ciel::NONE;
    let n = next.len();
    // mate_face: the opposite directed edge in the same cell.
    let mut mate_face = vec![NONE; n];
    for ci in 0..cell_start.len() - 1 {
        let r = cell_start[ci] as usize..cell_start[ci + 1] as usize;
        let by_edge: HashMap<(u32, u32), usize> =
            r.clone().map(|h| ((org(h), org(next[h])), h)).collect();
        for h in r {
            mate_face[h] = by_edge[&(org(next[h]), org(h))] as u32;
        }
    }
    // mate_cell: faces with the same vertex set in two cells, reversed.
    let mut by_set: HashMap<Vec<u32>, Vec<usize>> = HashMap::new();
    for (i, (_, r)) in faces.iter().enumerate() {
        let mut s: Vec<u32> = r.clone().map(|h| org(h as usize)).collect();
        s.sort_unstable();
        by_set.entry(s).or_default().push(i);
    }
    let mut mate_cell = vec![NONE; n];
    for group in by_set.values() {
        assert!(group.len() <= 2, "{label}: a face in {} cells", group.len());
        if group.len() == 2 {
            let (f, h) = (&faces[group[0]].1, &faces[group[1]].1);
            for a in f.clone() {
                let a = a as usize;
                let b = h
                    .clone()
                    .map(|b| b as usize)
                    .find(|&b| org(b) == org(next[a]) && org(next[b]) == org(a))
                    .unwrap_or_else(|| panic!("{label}: shared face not reversed"));
                mate_cell[a] = b as u32;
                mate_cell[b] = a as u32;
            }
        }
    }
    (mate_face, mate_cell)
}

/// The reference's fan representatives: the smallest half-edge of each
/// fan of half-edges around a vertex.
fn reference_reps(mate_face: &[u32], mate_cell: &[u32]) -> Vec<bool> {
    use stratasweep::structures::ciel::NONE;
    let n = mate_face.len();
    let mut is_rep = vec![false; n];
    let mut seen = vec![false; n];
    for h in 0..n {
        if seen[h] {
            continue;
        }
        let mut orbit = vec![h];
        let mut x = h;
        while let y = mate_cell[mate_face[x] as usize]
            && y != NONE
            && y as usize != h
        {
            orbit.push(y as usize);
            x = y as usize;
        }
        let mut x = h;
        while let m = mate_cell[x]
            && m != NONE
            && mate_face[m as usize] as usize != h
        {
            x = mate_face[m as usize] as usize;
            orbit.push(x);
        }
        for &y in &orbit {
            seen[y] = true;
        }
        is_rep[*orbit.iter().min().unwrap()] = true;
    }
    is_rep
}

#[test]
fn build_equals_a_straightforward_reference_field_by_field() {
    let mut rng = Rng(23);
    let mut checked = 0;
    for round in 0..10 {
        let n = [2 + rng.below(6), 2 + rng.below(6), 1 + rng.below(5)];
        let jitter = if round % 2 == 0 { 0.0 } else { 0.3 };
        let holes = [0.0, 0.15, 0.4][round % 3];
        let g = polyhedral(n, jitter, holes, &mut rng);
        let c = match Ciel::build(&g, g.hidden_cells().as_deref()) {
            Err(CielError::NoCells) => continue, // every cell hidden
            r => r.unwrap(),
        };
        check_against_reference_build(&g, &c, &format!("round {round} {n:?}"));
        checked += 1;
    }
    assert!(checked >= 6, "only {checked} grids with live cells");
    // Dead cells among the live ones leave gaps in the chunks' parts.
    for (cells, seed, dead_every) in [(50, 3, 1000), (400, 4, 90), (3000, 5, 700)] {
        let v = stratasweep::voronoi::voronoi(cells, seed);
        let g = scramble_faces(&v, &mut rng, dead_every);
        let c = Ciel::build(&g, None).unwrap();
        assert!(c.counts.flipped_faces > 0);
        assert_eq!(c.live_cells(), cells);
        check_against_reference_build(&g, &c, &format!("voronoi {cells}"));
    }
}
