//! The faces of a set of cells that no second cell shares, matched by
//! their sorted vertex ids in one hash pass, and their triangulation.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::hash::{BuildHasherDefault, Hasher};

use crate::grid::{Cells, vtk_type};
use crate::metacell::{
    HEXAHEDRON_FACES, PYRAMID_FACES, TETRA_FACES, VOXEL_TO_HEX, WEDGE_FACES, prism_faces,
};

/// A face's sorted vertex ids: faces of up to four vertices (all typed
/// cells) are kept inline, longer ones (polyhedra) on the heap.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum FaceKey {
    Small([u32; 4]),
    Long(Box<[u32]>),
}

impl FaceKey {
    fn of(sorted: &[u32]) -> Self {
        match sorted.len() {
            0..=4 => {
                let mut k = [u32::MAX; 4];
                k[..sorted.len()].copy_from_slice(sorted);
                FaceKey::Small(k)
            }
            _ => FaceKey::Long(sorted.into()),
        }
    }
}

/// A multiply-rotate hash of the face keys' words (FxHash's): the keys
/// are vertex ids, not attacker input, and SipHash was the pass's cost.
#[derive(Default)]
struct WordHasher(u64);

impl Hasher for WordHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..b.len()].copy_from_slice(b);
            self.write_u64(u64::from_le_bytes(w));
        }
    }
    fn write_u32(&mut self, i: u32) {
        self.write_u64(i as u64);
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
}

/// The faces seen an odd number of times so far: a face seen a second
/// time (by a neighbour) is dropped, as an inner face. Each open face keeps
/// its loop as the first cell gave it (outward for that cell).
#[derive(Default)]
pub(super) struct OpenFaces {
    /// Open face → its loop's start and length in `loops`.
    open: HashMap<FaceKey, (u32, u32), BuildHasherDefault<WordHasher>>,
    loops: Vec<u32>,
    sorted: Vec<u32>,
    clean: Vec<u32>,
}

impl OpenFaces {
    /// Adds one face loop of global point ids. Repeated consecutive ids
    /// (collapsed corners) are dropped; a loop left with fewer than three
    /// distinct ids is no face and is ignored.
    pub(super) fn toggle(&mut self, face: &[u32]) {
        self.clean.clear();
        for &v in face {
            if self.clean.last() != Some(&v) {
                self.clean.push(v);
            }
        }
        while self.clean.len() > 1 && self.clean.first() == self.clean.last() {
            self.clean.pop();
        }
        self.sorted.clear();
        self.sorted.extend_from_slice(&self.clean);
        self.sorted.sort_unstable();
        self.sorted.dedup();
        if self.sorted.len() < 3 {
            return;
        }
        let key = FaceKey::of(&self.sorted);
        match self.open.entry(key) {
            Entry::Occupied(e) => {
                e.remove();
            }
            Entry::Vacant(e) => {
                let start = self.loops.len() as u32;
                self.loops.extend_from_slice(&self.clean);
                e.insert((start, self.clean.len() as u32));
            }
        }
    }

    /// The open face loops, in the order their cells gave them (so the
    /// output does not depend on the hash order).
    pub(super) fn loops(&self) -> Vec<&[u32]> {
        let mut spans: Vec<(u32, u32)> = self.open.values().copied().collect();
        spans.sort_unstable();
        spans
            .into_iter()
            .map(|(s, n)| &self.loops[s as usize..(s + n) as usize])
            .collect()
    }
}

/// Adds every face of cell `c` of `cells` (outward loops of global ids
/// into `points`) to `open`. Lower-dimensional cells, unknown types and typed cells with the
/// wrong id count add nothing.
pub(super) fn toggle_cell_faces(
    cells: &Cells,
    points: &[[f64; 3]],
    c: usize,
    open: &mut OpenFaces,
) {
    let ids = cells.cell(c);
    match (cells.types[c], ids.len()) {
        (vtk_type::POLYHEDRON, _) => toggle_face_stream(cells.faces_of(c), points, open),
        (vtk_type::TETRA, 4) => toggle_local(&TETRA_FACES, ids, open),
        (vtk_type::PYRAMID, 5) => toggle_local(&PYRAMID_FACES, ids, open),
        (vtk_type::WEDGE, 6) => toggle_local(&WEDGE_FACES, ids, open),
        (vtk_type::HEXAHEDRON, 8) => toggle_local(&HEXAHEDRON_FACES, ids, open),
        (vtk_type::VOXEL, 8) => {
            let hex: [u32; 8] = std::array::from_fn(|v| ids[VOXEL_TO_HEX[v]]);
            toggle_local(&HEXAHEDRON_FACES, &hex, open);
        }
        (vtk_type::PENTAGONAL_PRISM, 10) => toggle_local(&prism_faces(5), ids, open),
        (vtk_type::HEXAGONAL_PRISM, 12) => toggle_local(&prism_faces(6), ids, open),
        _ => {}
    }
}

/// Adds the faces of a typed cell: `faces` are outward loops of local
/// vertex numbers, `ids` the cell's global ids in local order.
pub(super) fn toggle_local<F: AsRef<[u8]>>(faces: &[F], ids: &[u32], open: &mut OpenFaces) {
    // A face has at most as many vertices as its cell (meta-cells: 12).
    let mut face = [0u32; crate::metacell::MAX_META_VERTICES];
    for f in faces {
        let f = f.as_ref();
        for (slot, &v) in face.iter_mut().zip(f) {
            *slot = ids[v as usize];
        }
        open.toggle(&face[..f.len()]);
    }
}

/// Adds the faces of one polyhedron's VTK face stream (`nf, n0, ids.., ...`),
/// turned outward first ([`orient_outward`]). A truncated stream adds the
/// faces it holds whole.
fn toggle_face_stream(stream: &[u32], points: &[[f64; 3]], open: &mut OpenFaces) {
    let Some((&nf, mut rest)) = stream.split_first() else {
        return;
    };
    let mut faces: Vec<Vec<u32>> = Vec::with_capacity(nf as usize);
    for _ in 0..nf {
        let Some((&n, tail)) = rest.split_first() else {
            break;
        };
        let Some(ids) = tail.get(..n as usize) else {
            break;
        };
        faces.push(ids.to_vec());
        rest = &tail[n as usize..];
    }
    orient_outward(&mut faces, points);
    for f in &faces {
        open.toggle(f);
    }
}

/// Turns a polyhedron's face loops outward: files may list them either way
/// round (the GEOS PEBI grid does). From the first face, each face sharing
/// an edge with an oriented one is turned to run that edge the other way;
/// then, if the enclosed volume (cones from the vertex mean over fans
/// around the face means) is negative, every face is turned. Faces not
/// reached over edges keep their order.
fn orient_outward(faces: &mut [Vec<u32>], points: &[[f64; 3]]) {
    // (undirected edge, runs low → high, face), sorted by edge.
    let mut edges: Vec<(u64, bool, u32)> = Vec::with_capacity(faces.iter().map(Vec::len).sum());
    for (i, f) in faces.iter().enumerate() {
        for (k, &a) in f.iter().enumerate() {
            let b = f[(k + 1) % f.len()];
            edges.push(((a.min(b) as u64) << 32 | a.max(b) as u64, a < b, i as u32));
        }
    }
    edges.sort_unstable();
    // Already consistent (each edge run once each way): only the sign is left.
    let consistent = edges.len().is_multiple_of(2)
        && edges
            .chunks(2)
            .all(|p| p[0].0 == p[1].0 && p[0].1 != p[1].1)
        && edges.windows(3).all(|w| w[0].0 != w[2].0);
    if !consistent {
        let mut done = vec![false; faces.len()];
        for seed in 0..faces.len() {
            if done[seed] {
                continue;
            }
            done[seed] = true;
            let mut stack = vec![seed];
            while let Some(i) = stack.pop() {
                for k in 0..faces[i].len() {
                    let (a, b) = (faces[i][k], faces[i][(k + 1) % faces[i].len()]);
                    let key = (a.min(b) as u64) << 32 | a.max(b) as u64;
                    let from = edges.partition_point(|e| e.0 < key);
                    for e in edges[from..].iter().take_while(|e| e.0 == key) {
                        let j = e.2 as usize;
                        if done[j] {
                            continue;
                        }
                        // j must run b → a: reverse it if it runs a → b.
                        let g = &faces[j];
                        if (0..g.len()).any(|m| g[m] == a && g[(m + 1) % g.len()] == b) {
                            faces[j].reverse();
                        }
                        done[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
    }
    if signed_volume6(faces, points) < 0.0 {
        faces.iter_mut().for_each(|f| f.reverse());
    }
}

/// Six times the volume enclosed by `faces`: cones from the vertex mean
/// over each face fanned around its own vertex mean.
fn signed_volume6(faces: &[Vec<u32>], points: &[[f64; 3]]) -> f64 {
    let mean = |ids: &mut dyn Iterator<Item = &u32>| {
        let (mut m, mut n) = ([0.0; 3], 0.0);
        for &v in ids {
            let p = points[v as usize];
            (0..3).for_each(|a| m[a] += p[a]);
            n += 1.0;
        }
        m.map(|x| x / n)
    };
    let c = mean(&mut faces.iter().flatten());
    let rel = |v: u32| {
        let p = points[v as usize];
        [p[0] - c[0], p[1] - c[1], p[2] - c[2]]
    };
    let mut six = 0.0;
    for f in faces {
        let m = mean(&mut f.iter());
        let m = [m[0] - c[0], m[1] - c[1], m[2] - c[2]];
        let mut prev = rel(*f.last().expect("faces have ids"));
        for &v in f {
            let p = rel(v);
            six += m[0] * (prev[1] * p[2] - prev[2] * p[1])
                - m[1] * (prev[0] * p[2] - prev[2] * p[0])
                + m[2] * (prev[0] * p[1] - prev[1] * p[0]);
            prev = p;
        }
    }
    six
}

/// Triangulates face loops over `points`: a triangle as itself, a longer
/// loop as a fan around its vertex mean, which is appended to `points`
/// (the same split [`crate::metacell::MetaCell::signed_volume`] measures
/// cells with). Triangles keep the loop's orientation.
pub(super) fn triangulate(loops: &[&[u32]], points: &mut Vec<[f64; 3]>) -> Vec<[u32; 3]> {
    let mut tris = Vec::new();
    for f in loops {
        if let [a, b, c] = f {
            tris.push([*a, *b, *c]);
            continue;
        }
        let mut m = [0.0; 3];
        for &v in *f {
            let p = points[v as usize];
            for a in 0..3 {
                m[a] += p[a];
            }
        }
        let m = m.map(|x| x / f.len() as f64);
        let centre = points.len() as u32;
        points.push(m);
        let mut prev = *f.last().expect("faces have three or more ids");
        for &v in *f {
            tris.push([centre, prev, v]);
            prev = v;
        }
    }
    tris
}
