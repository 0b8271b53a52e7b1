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

/// Adds every face of cell `c` of `cells` (outward loops of global ids) to
/// `open`. Lower-dimensional cells, unknown types and typed cells with the
/// wrong id count add nothing.
pub(super) fn toggle_cell_faces(cells: &Cells, c: usize, open: &mut OpenFaces) {
    let ids = cells.cell(c);
    match (cells.types[c], ids.len()) {
        (vtk_type::POLYHEDRON, _) => toggle_face_stream(cells.faces_of(c), open),
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
    let mut face = [0u32; 8];
    for f in faces {
        let f = f.as_ref();
        for (slot, &v) in face.iter_mut().zip(f) {
            *slot = ids[v as usize];
        }
        open.toggle(&face[..f.len()]);
    }
}

/// Adds the faces of one polyhedron's VTK face stream (`nf, n0, ids.., ...`).
/// A truncated stream adds the faces it holds whole.
fn toggle_face_stream(stream: &[u32], open: &mut OpenFaces) {
    let Some((&nf, mut rest)) = stream.split_first() else {
        return;
    };
    for _ in 0..nf {
        let Some((&n, tail)) = rest.split_first() else {
            return;
        };
        let Some(ids) = tail.get(..n as usize) else {
            return;
        };
        open.toggle(ids);
        rest = &tail[n as usize..];
    }
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
