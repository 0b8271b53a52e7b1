//! A clipped 3D Voronoi grid (like the paper's Voronoi data set): N random
//! sites in the unit box; each cell is the box cut by the bisector
//! half-spaces of its neighbours, found nearest first with a k-d tree
//! (`kiddo`) until the security radius proves no farther site can cut.
//!
//! Every cell vertex is labelled by the planes that make it (bisectors by
//! the neighbour's site id, box faces by `N + face`); with the cell's own
//! site added, that set is the same in every cell sharing the vertex, so
//! vertices are merged exactly (a conforming grid) without any tolerance.
//! Cells are VTK polyhedra with outward faces and a smooth point property
//! `f`. No I/O.

use std::collections::HashMap;
use std::num::NonZero;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::grid::{Cells, Grid, Property, Topology};
use crate::vec3::{dot, sub};

/// A polyhedron vertex: position and the three planes through it.
#[derive(Clone, Copy, Debug)]
struct Vert {
    p: [f64; 3],
    planes: [u32; 3],
}

/// A convex polyhedron as faces (plane id, vertex loop).
#[derive(Clone, Debug, Default)]
struct Poly {
    verts: Vec<Vert>,
    faces: Vec<(u32, Vec<u32>)>,
}

/// The unit box with plane ids `base + face` (−x, +x, −y, +y, −z, +z).
fn unit_box(base: u32) -> Poly {
    let mut verts = Vec::new();
    for i in 0..8u32 {
        let (x, y, z) = (i & 1, (i >> 1) & 1, (i >> 2) & 1);
        verts.push(Vert {
            p: [x as f64, y as f64, z as f64],
            planes: [base + x, base + 2 + y, base + 4 + z],
        });
    }
    // Outward loops (vertex index = x + 2y + 4z).
    let faces = vec![
        (base, vec![0, 4, 6, 2]),
        (base + 1, vec![1, 3, 7, 5]),
        (base + 2, vec![0, 1, 5, 4]),
        (base + 3, vec![2, 6, 7, 3]),
        (base + 4, vec![0, 2, 3, 1]),
        (base + 5, vec![4, 5, 7, 6]),
    ];
    Poly { verts, faces }
}

impl Poly {
    /// Keeps the half-space `n·x ≤ d` (plane id `id`). Returns whether it cut.
    fn clip(&mut self, n: [f64; 3], d: f64, id: u32) -> bool {
        let side: Vec<f64> = self.verts.iter().map(|v| dot(n, v.p) - d).collect();
        if side.iter().all(|&s| s <= 0.0) {
            return false;
        }
        let mut verts: Vec<Vert> = Vec::with_capacity(self.verts.len() + 8);
        let mut remap = vec![u32::MAX; self.verts.len()];
        for (i, v) in self.verts.iter().enumerate() {
            if side[i] <= 0.0 {
                remap[i] = verts.len() as u32;
                verts.push(*v);
            }
        }
        // New vertices on cut edges, shared by the two faces of the edge.
        let mut cut: HashMap<(u32, u32), u32> = HashMap::new();
        let mut faces = Vec::with_capacity(self.faces.len() + 1);
        let mut new_face: Vec<(u32, u32)> = Vec::new(); // segments (from, to) on the new face
        for (fid, lp) in &self.faces {
            let mut out = Vec::with_capacity(lp.len() + 2);
            let mut enter = u32::MAX;
            let mut exit = u32::MAX;
            for k in 0..lp.len() {
                let (a, b) = (lp[k] as usize, lp[(k + 1) % lp.len()] as usize);
                let (sa, sb) = (side[a] <= 0.0, side[b] <= 0.0);
                if sa {
                    out.push(remap[a]);
                }
                if sa != sb {
                    let key = (a.min(b) as u32, a.max(b) as u32);
                    let vid = *cut.entry(key).or_insert_with(|| {
                        let (va, vb) = (self.verts[a], self.verts[b]);
                        let t = side[a] / (side[a] - side[b]);
                        let p = [0, 1, 2].map(|c| va.p[c] + t * (vb.p[c] - va.p[c]));
                        // The edge lies on the two planes common to a and b.
                        let mut common = [u32::MAX; 2];
                        let mut m = 0;
                        for &q in &va.planes {
                            if vb.planes.contains(&q) && m < 2 {
                                common[m] = q;
                                m += 1;
                            }
                        }
                        verts.push(Vert {
                            p,
                            planes: [common[0], common[1], id],
                        });
                        (verts.len() - 1) as u32
                    });
                    out.push(vid);
                    if sa {
                        exit = vid;
                    } else {
                        enter = vid;
                    }
                }
            }
            if exit != u32::MAX && enter != u32::MAX {
                // The clipped face has the cut edge exit → enter; the new face
                // (outward along n) traverses it the other way, enter → exit.
                new_face.push((exit, enter));
            }
            if out.len() >= 3 {
                faces.push((*fid, out));
            }
        }
        // Chain the edges enter → exit into the new face loop (one face's
        // exit is the next face's enter).
        if new_face.len() >= 3 {
            let next: HashMap<u32, u32> = new_face.iter().map(|&(a, b)| (b, a)).collect();
            let start = new_face[0].1;
            let mut lp = vec![start];
            let mut x = start;
            for _ in 0..new_face.len() {
                match next.get(&x) {
                    Some(&y) if y != start => {
                        lp.push(y);
                        x = y;
                    }
                    _ => break,
                }
            }
            if lp.len() >= 3 {
                faces.push((id, lp));
            }
        }
        // Drop unused vertices.
        let mut used = vec![u32::MAX; verts.len()];
        let mut vs = Vec::with_capacity(verts.len());
        for (_, lp) in faces.iter_mut() {
            for v in lp.iter_mut() {
                if used[*v as usize] == u32::MAX {
                    used[*v as usize] = vs.len() as u32;
                    vs.push(verts[*v as usize]);
                }
                *v = used[*v as usize];
            }
        }
        self.verts = vs;
        self.faces = faces;
        true
    }
}

/// The Voronoi cell of site `i` (clipped to the unit box).
fn cell(i: usize, sites: &[[f64; 3]], tree: &ImmutableKdTree<f64, 3>) -> Poly {
    let n = sites.len();
    let s = sites[i];
    let mut poly = unit_box(n as u32);
    let mut k = 32usize.min(n);
    let mut done = 1usize; // neighbours already applied (skip self at 0)
    loop {
        let nn = tree
            .query(&s)
            .nearest_n::<SquaredEuclidean<f64>>(NonZero::new(k).expect("k > 0"))
            .execute();
        for q in nn.iter().skip(done) {
            let j = q.item as usize;
            if j == i {
                continue;
            }
            // Security radius: no site farther than twice the farthest
            // vertex can cut the cell.
            let r2 = poly
                .verts
                .iter()
                .map(|v| {
                    let d = sub(v.p, s);
                    dot(d, d)
                })
                .fold(0.0, f64::max);
            if q.distance > 4.0 * r2 {
                return poly;
            }
            let nrm = sub(sites[j], s);
            let mid = [0, 1, 2].map(|c| 0.5 * (sites[j][c] + s[c]));
            poly.clip(nrm, dot(nrm, mid), j as u32);
        }
        done = nn.len();
        if k >= n {
            return poly;
        }
        k = (k * 2).min(n);
    }
}

/// Morton code of a point of the unit box (21 bits per axis).
fn morton(p: [f64; 3]) -> u64 {
    let spread = |x: f64| {
        let mut v = (x.clamp(0.0, 1.0) * ((1u64 << 21) - 1) as f64) as u64;
        v = (v | v << 32) & 0x1f_0000_0000_ffff;
        v = (v | v << 16) & 0x1f_0000_ff00_00ff;
        v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
        v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
        v = (v | v << 2) & 0x1249_2492_4924_9249;
        v
    };
    spread(p[0]) | spread(p[1]) << 1 | spread(p[2]) << 2
}

/// Smooth point property of the Voronoi grid.
pub fn voronoi_field(p: [f64; 3]) -> f64 {
    (3.0 * p[0]).sin() * (2.0 * p[1]).cos() + p[2] * p[2] + 0.5 * (4.0 * p[0] * p[1]).sin()
}

/// A clipped Voronoi grid of `cells` random sites (seeded) in the unit box,
/// as conforming VTK polyhedra with point property `f`.
pub fn voronoi(cells: usize, seed: u64) -> Grid {
    let n = cells.max(1);
    let mut state = seed ^ 0x005E_ED0F_C1E1;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut sites: Vec<[f64; 3]> = (0..n).map(|_| [next(), next(), next()]).collect();
    // Cells (and so first-use vertex ids) in Morton order: neighbours sit
    // close in memory, as in grids written by meshers.
    sites.sort_by_cached_key(|p| morton(*p));
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(&sites).expect("k-d tree of the sites");
    let polys: Vec<Poly> = (0..n)
        .into_par_iter()
        .map(|i| cell(i, &sites, &tree))
        .collect();
    // Merge vertices by their plane labels plus the owning site.
    let mut ids: HashMap<[u32; 4], u32> = HashMap::new();
    let mut points: Vec<[f64; 3]> = Vec::new();
    let mut out = Cells::default();
    let mut faces: Vec<Vec<u32>> = Vec::new();
    for (i, poly) in polys.iter().enumerate() {
        let gid: Vec<u32> = poly
            .verts
            .iter()
            .map(|v| {
                let mut key = [i as u32, v.planes[0], v.planes[1], v.planes[2]];
                key.sort_unstable();
                *ids.entry(key).or_insert_with(|| {
                    points.push(v.p);
                    (points.len() - 1) as u32
                })
            })
            .collect();
        faces.clear();
        for (_, lp) in &poly.faces {
            let mut f: Vec<u32> = lp.iter().map(|&v| gid[v as usize]).collect();
            f.dedup();
            while f.len() > 1 && f.first() == f.last() {
                f.pop();
            }
            if f.len() >= 3 {
                faces.push(f);
            }
        }
        out.push_polyhedron(&faces);
    }
    let f: Vec<f64> = points.iter().map(|&p| voronoi_field(p)).collect();
    Grid {
        points,
        topology: Topology::Unstructured(out),
        point_data: vec![Property::scalar("f", f)],
        cell_data: vec![],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_interleaves_bits() {
        let one = 1.0 / ((1u64 << 21) - 1) as f64;
        assert_eq!(morton([one, 0.0, 0.0]), 1);
        assert_eq!(morton([0.0, one, 0.0]), 2);
        assert_eq!(morton([0.0, 0.0, one]), 4);
        assert_eq!(morton([1.0, 1.0, 1.0]), (1u64 << 63) - 1);
        assert!(morton([0.1, 0.1, 0.1]) < morton([0.9, 0.9, 0.9]));
    }

    #[test]
    fn clipped_box_volume() {
        let mut p = unit_box(100);
        assert!(p.clip([1.0, 0.0, 0.0], 0.5, 7));
        assert_eq!(p.faces.len(), 6);
    }
}
