//! The shapes of corner-point cells after merging coincident corners, the
//! per-cell codes of the conversion's first pass, and the small searches
//! the welding uses.

use crate::grid::vtk_type;
use crate::metacell::{HEXAHEDRON_FACES, MAX_META_VERTICES};

/// Corner-point corner numbers of VTK's hexahedron vertices when the
/// (i, j, k) frame is left-handed in world space (the usual case: i east,
/// j north, k down): VTK's bottom face is the k+1 (deeper) layer.
pub(super) const VTK_ORDER_LEFT: [usize; 8] = [4, 5, 7, 6, 0, 1, 3, 2];
/// The same when (i, j, k) is right-handed (e.g. j south).
pub(super) const VTK_ORDER_RIGHT: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// Shape of one cell after merging its coincident corners.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Shape {
    /// VTK typed cell: type and local corner numbers (corner-point numbering).
    Typed(u8, Vec<u8>),
    /// Polyhedron: outward faces as loops of corner numbers.
    Poly(Vec<Vec<u8>>),
    /// Fewer than four faces: no volume.
    Flat,
}

/// The merge pattern of a cell whose only coincident corners are on
/// collapsed pillar edges (bit `p` of `collapsed` for pillar corner
/// `p = ii + 2·jj`: corners `p` and `p + 4` coincide).
pub(super) fn pillar_pattern(collapsed: u8) -> [u8; 8] {
    std::array::from_fn(|c| {
        if c >= 4 && collapsed >> (c - 4) & 1 == 1 {
            (c - 4) as u8
        } else {
            c as u8
        }
    })
}

/// Classifies a cell from its merge pattern (`rep[c]`: the smallest corner
/// coinciding with corner `c`, corner-point numbering), given the VTK order
/// in use. The faces are the hexahedron's with merged corners removed;
/// faces left with fewer than three corners vanish. 8 distinct corners give
/// a hexahedron; a closed surface of 2 triangles and 3 quads, of 4
/// triangles and 1 quad, or of 4 triangles gives a wedge, a pyramid or a
/// tetrahedron; other closed surfaces a polyhedron. `None` when the merged
/// faces are not a closed, consistently oriented surface (a face passing
/// twice through a corner, an edge used twice in one direction).
pub(super) fn shape_of(rep: &[u8; 8], order: &[usize; 8]) -> Option<Shape> {
    if rep.iter().enumerate().all(|(c, &r)| r as usize == c) {
        return Some(Shape::Typed(
            vtk_type::HEXAHEDRON,
            order.iter().map(|&c| c as u8).collect(),
        ));
    }
    let mut faces: Vec<Vec<u8>> = Vec::new();
    for f in HEXAHEDRON_FACES {
        let mut loop_: Vec<u8> = f.iter().map(|&l| rep[order[l as usize]]).collect();
        loop_.dedup();
        while loop_.len() > 1 && loop_.first() == loop_.last() {
            loop_.pop();
        }
        if loop_.len() < 3 {
            continue;
        }
        let mut s = loop_.clone();
        s.sort_unstable();
        if s.windows(2).any(|w| w[0] == w[1]) {
            return None;
        }
        faces.push(loop_);
    }
    if faces.len() < 4 {
        return Some(Shape::Flat);
    }
    // Closed and consistently oriented: each directed edge once, with its reverse.
    let mut directed: Vec<(u8, u8)> = faces
        .iter()
        .flat_map(|f| (0..f.len()).map(move |i| (f[i], f[(i + 1) % f.len()])))
        .collect();
    directed.sort_unstable();
    if directed.windows(2).any(|w| w[0] == w[1])
        || directed
            .iter()
            .any(|&(a, b)| directed.binary_search(&(b, a)).is_err())
    {
        return None;
    }
    let mut verts: Vec<u8> = faces.iter().flatten().copied().collect();
    verts.sort_unstable();
    verts.dedup();
    let tris: Vec<&Vec<u8>> = faces.iter().filter(|f| f.len() == 3).collect();
    let quads: Vec<&Vec<u8>> = faces.iter().filter(|f| f.len() == 4).collect();
    let not_on =
        |f: &[u8]| -> Vec<u8> { verts.iter().copied().filter(|v| !f.contains(v)).collect() };
    let has_edge = |a: u8, b: u8| directed.binary_search(&(a, b)).is_ok();
    Some(match (verts.len(), tris.len(), quads.len()) {
        (6, 2, 3) => {
            // VTK wedge: face (0, 2, 1) outward, (3, 4, 5) outward,
            // vertex i+3 joined to vertex i.
            let t = tris[0];
            let (p0, p2, p1) = (t[0], t[1], t[2]);
            let u = tris[1];
            let partner = |p: u8| u.iter().copied().find(|&q| has_edge(p, q));
            match (partner(p0), partner(p1), partner(p2)) {
                (Some(a), Some(b), Some(c)) if a != b && b != c && a != c => {
                    Shape::Typed(vtk_type::WEDGE, vec![p0, p1, p2, a, b, c])
                }
                _ => Shape::Poly(faces),
            }
        }
        (5, 4, 1) => {
            // VTK pyramid: base (0, 3, 2, 1) outward, apex 4.
            let q = quads[0];
            let apex = not_on(q);
            Shape::Typed(vtk_type::PYRAMID, vec![q[0], q[3], q[2], q[1], apex[0]])
        }
        (4, 4, 0) => {
            // VTK tetra: (0, 2, 1) outward, apex 3.
            let t = tris[0];
            let apex = not_on(t);
            Shape::Typed(vtk_type::TETRA, vec![t[0], t[2], t[1], apex[0]])
        }
        (n, _, _) if n <= MAX_META_VERTICES => Shape::Poly(faces),
        _ => return None,
    })
}

/// Per-cell code of the conversion's first pass: bits 0–3 the collapsed
/// pillar edges, then the flags below.
pub(super) const CODE_ACTIVE: u8 = 0x80;
/// (Near) zero volume, or a flat merge pattern: dropped.
pub(super) const CODE_ZERO: u8 = 0x40;
/// Negative signed trilinear volume.
pub(super) const CODE_NEG: u8 = 0x20;
/// Corners on different pillars coincide (merged through the side list).
pub(super) const CODE_CROSS: u8 = 0x10;

/// Whether a first-pass code is a kept cell.
#[inline(always)]
pub(super) fn kept(code: u8) -> bool {
    code & (CODE_ACTIVE | CODE_ZERO) == CODE_ACTIVE
}

/// A cell whose corners coincide across pillars.
pub(super) struct CrossCell {
    /// IJK index.
    pub(super) cell: usize,
    /// Merge pattern (see [`shape_of`]).
    pub(super) rep: [u8; 8],
    /// |trilinear volume|.
    pub(super) volume: f64,
}

/// The merge pattern of a cell (see [`shape_of`]) when corners on
/// different pillars coincide (within `tol` in every coordinate), else
/// `None`. Corners on the same pillar merge only at equal depths, as the
/// welding does.
pub(super) fn cross_pattern(corners: &[[f64; 3]; 8], z: &[f64; 8], tol: f64) -> Option<[u8; 8]> {
    let mut rep = [0u8; 8];
    let mut cross = false;
    for a in 0..8 {
        rep[a] = a as u8;
        for b in 0..a {
            if rep[b] as usize != b {
                continue;
            }
            let same = if a ^ b == 4 {
                z[a] == z[b]
            } else {
                (0..3).all(|d| (corners[a][d] - corners[b][d]).abs() <= tol)
            };
            if same {
                rep[a] = b as u8;
                cross |= a ^ b != 4;
                break;
            }
        }
    }
    cross.then_some(rep)
}

/// Index of the first element of the sorted `d` not below `z` (total
/// order), searched by galloping from `guess`.
pub(super) fn search_from(d: &[f64], z: f64, guess: usize) -> usize {
    let below = |x: &f64| x.total_cmp(&z).is_lt();
    let n = d.len();
    if n == 0 {
        return 0;
    }
    let g = guess.min(n - 1);
    let (mut lo, mut hi, mut step) = (g, g, 1);
    if below(&d[g]) {
        // Answer in (g, n]: d[..lo] below z.
        lo = g + 1;
        hi = lo;
        while hi < n && below(&d[hi]) {
            lo = hi + 1;
            hi += step;
            step *= 2;
        }
        hi = hi.min(n);
    } else {
        // Answer in [0, g]: d[hi] not below z.
        while lo > 0 {
            lo = hi.saturating_sub(step);
            if below(&d[lo]) {
                break;
            }
            hi = lo;
            step *= 2;
        }
    }
    lo + d[lo..hi].partition_point(below)
}

/// Union-find root with path halving.
pub(super) fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        let p = parent[parent[v as usize] as usize];
        parent[v as usize] = p;
        v = p;
    }
    v
}
