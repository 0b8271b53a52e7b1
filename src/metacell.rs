//! Meta-cells: everything about one cell *type*, stored once per type, with
//! marching-polyhedra tables generated automatically from the face
//! description.
//!
//! Conventions:
//! * Configuration code: bit `i` set ⇔ local vertex `i` is *above* the level
//!   (φ ≥ t).
//! * Faces are vertex loops oriented outward (right-hand rule).
//! * Inside a face, the intersection segment runs from a *down* side (above →
//!   below in face order) to an *up* side (below → above). With that rule the
//!   loops come out oriented with their normal toward increasing φ, and a face
//!   shared by two cells is traversed in opposite directions by each, which
//!   makes the surface consistently oriented.
//! * A face crossed more than twice is *ambiguous*. Its crossings are paired
//!   according to one decider bit per face: `1` = the above arcs are connected
//!   across the face (each segment cuts off a below arc), `0` = the below arcs
//!   are connected (each segment cuts off an above arc). Tables store one loop
//!   set per combination of decider bits ("variant").

use std::collections::HashMap;
use thiserror::Error;

use crate::grid::vtk_type;
use crate::vec3::{add, cross, dot, sub};

/// Largest vertex count of a meta-cell (codes are `u16`-sized tables of 2^nv entries).
pub const MAX_META_VERTICES: usize = 12;

/// Largest number of ambiguous faces one code may have (variants are 2^n).
const MAX_AMBIGUOUS_FACES: u32 = 10;

/// Errors raised while building a meta-cell from a face description.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MetaCellError {
    /// Too many vertices for a table-driven meta-cell.
    #[error("{nv} vertices: meta-cells hold at most {MAX_META_VERTICES} (larger cells need CIEL)")]
    TooManyVertices {
        /// Vertex count.
        nv: usize,
    },
    /// A face with fewer than 3 vertices or a repeated vertex.
    #[error("face {face} is degenerate ({why})")]
    BadFace {
        /// Face index.
        face: usize,
        /// Why.
        why: &'static str,
    },
    /// The faces do not form a closed, consistently oriented 2-manifold.
    #[error(
        "edge {a}-{b} is used {count} time(s) in the same direction or not matched by an opposite face side: the faces are not a closed, consistently oriented surface"
    )]
    NotClosed {
        /// Local vertex.
        a: u8,
        /// Local vertex.
        b: u8,
        /// How often it was used in one direction.
        count: usize,
    },
    /// A local vertex used by no face.
    #[error("local vertex {0} is on no face")]
    UnusedVertex(usize),
    /// Too many ambiguous faces for the variant tables.
    #[error("a configuration has {0} ambiguous faces; at most {MAX_AMBIGUOUS_FACES} are supported")]
    TooAmbiguous(u32),
}

/// A cell type with its generated marching-polyhedra tables.
#[derive(Clone, Debug)]
pub struct MetaCell {
    /// Human-readable name (`hexahedron`, `polyhedron(10v,7f)`, ...).
    pub name: String,
    /// Local vertex count.
    pub nv: usize,
    /// Faces as outward-oriented loops of local vertex ids.
    pub faces: Vec<Vec<u8>>,
    /// Edges as `[a, b]` with `a < b`, derived from the faces.
    pub edges: Vec<[u8; 2]>,
    /// Per code: bit mask of the faces that are ambiguous for that code.
    pub ambiguous_faces: Vec<u32>,
    /// Per code: index of its first variant in `variant_loops`.
    pub variant_base: Vec<u32>,
    /// Per variant: `variant_loops[v]..variant_loops[v+1]` indexes `config_size`
    /// (one extra entry at the end).
    pub variant_loops: Vec<u32>,
    /// Per loop: its vertex count (the paper's `config_size`).
    pub config_size: Vec<u8>,
    /// Per loop: start of its edges in `config` (one extra entry at the end).
    pub loop_start: Vec<u32>,
    /// Intersected local edges of every loop, in the order met when turning
    /// around the faces (the paper's `config`).
    pub config: Vec<u8>,
    /// The faces again, as a fixed array, when the cell has 8 vertices and
    /// 6 quadrilateral faces (the hexahedron): [`MetaCell::signed_volume`]
    /// then runs a fully unrolled loop.
    hex_faces: Option<[[u8; 4]; 6]>,
    /// Per face, the bit set of its local vertices.
    face_masks: Vec<u16>,
}

impl MetaCell {
    /// Builds a meta-cell and all its tables from outward-oriented faces.
    pub fn from_faces(
        name: impl Into<String>,
        nv: usize,
        faces: Vec<Vec<u8>>,
    ) -> Result<Self, MetaCellError> {
        if nv > MAX_META_VERTICES {
            return Err(MetaCellError::TooManyVertices { nv });
        }
        let edges = closed_surface_edges(nv, &faces)?;
        let edge_id = |a: u8, b: u8| -> u8 {
            let k = if a < b { [a, b] } else { [b, a] };
            edges.binary_search(&k).expect("edge derived from faces") as u8
        };
        // Per face side: (edge id, from vertex, to vertex).
        let sides: Vec<Vec<(u8, u8, u8)>> = faces
            .iter()
            .map(|f| {
                (0..f.len())
                    .map(|i| {
                        (
                            edge_id(f[i], f[(i + 1) % f.len()]),
                            f[i],
                            f[(i + 1) % f.len()],
                        )
                    })
                    .collect()
            })
            .collect();

        let ncodes = 1usize << nv;
        let hex_faces = (nv == 8 && faces.len() == 6 && faces.iter().all(|f| f.len() == 4))
            .then(|| std::array::from_fn(|f| std::array::from_fn(|k| faces[f][k])));
        let face_masks = faces
            .iter()
            .map(|f| f.iter().fold(0u16, |m, &v| m | 1 << (v & 15)))
            .collect();
        let mut mc = MetaCell {
            name: name.into(),
            nv,
            faces,
            edges,
            ambiguous_faces: Vec::with_capacity(ncodes),
            variant_base: Vec::with_capacity(ncodes),
            variant_loops: vec![0],
            config_size: Vec::new(),
            loop_start: vec![0],
            config: Vec::new(),
            hex_faces,
            face_masks,
        };
        let mut next = vec![u8::MAX; mc.edges.len()];
        for code in 0..ncodes {
            mc.add_code(code, &sides, &mut next)?;
        }
        Ok(mc)
    }

    /// Appends the tables of one configuration code: its ambiguous-face mask
    /// and, per face-decider outcome, the loops of cut edges (`next` is
    /// scratch, one entry per edge).
    fn add_code(
        &mut self,
        code: usize,
        sides: &[Vec<(u8, u8, u8)>],
        next: &mut [u8],
    ) -> Result<(), MetaCellError> {
        let above = |v: u8| code >> v & 1 == 1;
        let mut mask = 0u32;
        for (fi, s) in sides.iter().enumerate() {
            if s.iter().filter(|&&(_, a, b)| above(a) != above(b)).count() > 2 {
                mask |= 1 << fi;
            }
        }
        if mask.count_ones() > MAX_AMBIGUOUS_FACES {
            return Err(MetaCellError::TooAmbiguous(mask.count_ones()));
        }
        self.ambiguous_faces.push(mask);
        self.variant_base.push(self.variant_loops.len() as u32 - 1);
        for outcome in 0..1u32 << mask.count_ones() {
            next.fill(u8::MAX);
            let mut bit = 0;
            for (fi, s) in sides.iter().enumerate() {
                let above_connected = if mask >> fi & 1 == 1 {
                    bit += 1;
                    outcome >> (bit - 1) & 1 == 1
                } else {
                    false
                };
                pair_face_sides(s, &above, above_connected, next);
            }
            // Cycles of `next`, started from the smallest unused edge.
            for start in 0..next.len() {
                if next[start] == u8::MAX {
                    continue;
                }
                let mut e = start;
                let mut len = 0u8;
                let at = self.config.len();
                while next[e] != u8::MAX {
                    self.config.push(e as u8);
                    len += 1;
                    let n = next[e] as usize;
                    next[e] = u8::MAX;
                    e = n;
                }
                if len < 3 {
                    // Two faces sharing two edges (a pinched corner-point
                    // cell): the loop is a doubled segment with no area.
                    self.config.truncate(at);
                    continue;
                }
                self.config_size.push(len);
                self.loop_start.push(self.config.len() as u32);
            }
            self.variant_loops.push(self.config_size.len() as u32);
        }
        Ok(())
    }

    /// Number of configuration codes (2^nv).
    pub fn code_count(&self) -> usize {
        1 << self.nv
    }

    /// True when code `code` has at least one ambiguous face.
    pub fn config_is_ambiguous(&self, code: usize) -> bool {
        self.ambiguous_faces[code] != 0
    }

    /// Loops of `code` for the decider `outcome` bits (one bit per ambiguous
    /// face, in increasing face order): an iterator of edge-id slices.
    pub fn loops(&self, code: usize, outcome: u32) -> impl Iterator<Item = &[u8]> + '_ {
        let v = (self.variant_base[code] + outcome) as usize;
        let (a, b) = (
            self.variant_loops[v] as usize,
            self.variant_loops[v + 1] as usize,
        );
        (a..b).map(move |l| {
            &self.config[self.loop_start[l] as usize..self.loop_start[l + 1] as usize]
        })
    }

    /// Bytes held by the tables.
    pub fn table_bytes(&self) -> usize {
        self.ambiguous_faces.len() * 4
            + self.variant_base.len() * 4
            + self.variant_loops.len() * 4
            + self.config_size.len()
            + self.loop_start.len() * 4
            + self.config.len()
    }
}

/// Checks that `faces` (loops of local vertex ids below `nv`) form a closed
/// oriented surface using every vertex (each directed edge once, its
/// reverse once) and returns its edges, sorted, each as `[a, b]` with a < b.
fn closed_surface_edges(nv: usize, faces: &[Vec<u8>]) -> Result<Vec<[u8; 2]>, MetaCellError> {
    let mut directed: HashMap<(u8, u8), usize> = HashMap::new();
    let mut used = vec![false; nv];
    for (fi, f) in faces.iter().enumerate() {
        if f.len() < 3 {
            return Err(MetaCellError::BadFace {
                face: fi,
                why: "fewer than 3 vertices",
            });
        }
        let mut s = f.clone();
        s.sort_unstable();
        if s.windows(2).any(|w| w[0] == w[1]) {
            return Err(MetaCellError::BadFace {
                face: fi,
                why: "repeated vertex",
            });
        }
        for i in 0..f.len() {
            let (a, b) = (f[i], f[(i + 1) % f.len()]);
            if a as usize >= nv || b as usize >= nv {
                return Err(MetaCellError::BadFace {
                    face: fi,
                    why: "vertex id out of range",
                });
            }
            used[a as usize] = true;
            *directed.entry((a, b)).or_default() += 1;
        }
    }
    if let Some(v) = used.iter().position(|u| !u) {
        return Err(MetaCellError::UnusedVertex(v));
    }
    for (&(a, b), &n) in &directed {
        if n != 1 || directed.get(&(b, a)) != Some(&1) {
            return Err(MetaCellError::NotClosed { a, b, count: n });
        }
    }
    let mut edges: Vec<[u8; 2]> = directed
        .keys()
        .filter(|(a, b)| a < b)
        .map(|&(a, b)| [a, b])
        .collect();
    edges.sort_unstable();
    Ok(edges)
}

/// Pairs the crossings of one face: for each down side, the up side that
/// closes its segment (see the module docs), written into `next[edge]`.
fn pair_face_sides(
    sides: &[(u8, u8, u8)],
    above: &impl Fn(u8) -> bool,
    above_connected: bool,
    next: &mut [u8],
) {
    let n = sides.len();
    for i in 0..n {
        let (e, a, b) = sides[i];
        if !above(a) || above(b) {
            continue; // not a down side
        }
        // Search for the matching up side.
        for step in 1..n {
            let j = if above_connected {
                (i + step) % n
            } else {
                (i + n - step) % n
            };
            let (u, ua, ub) = sides[j];
            if !above(ua) && above(ub) {
                next[e as usize] = u;
                break;
            }
        }
    }
}

/// Key of a meta-cell in the catalog.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum MetaKey {
    /// A VTK typed cell (voxels map to hexahedra).
    Vtk(u8),
    /// A polyhedron given by its local face loops.
    Faces(Vec<Vec<u8>>),
}

/// The catalog of meta-cells in use by one grid.
#[derive(Clone, Debug)]
pub struct Catalog {
    /// The meta-cells; the index is the meta-cell id stored per cell.
    pub metas: Vec<MetaCell>,
    ids: HashMap<MetaKey, u16>,
}

/// Outward faces of VTK's tetrahedron.
pub const TETRA_FACES: [&[u8]; 4] = [&[0, 1, 3], &[1, 2, 3], &[2, 0, 3], &[0, 2, 1]];
/// Outward faces of VTK's pyramid.
pub const PYRAMID_FACES: [&[u8]; 5] = [
    &[0, 3, 2, 1],
    &[0, 1, 4],
    &[1, 2, 4],
    &[2, 3, 4],
    &[3, 0, 4],
];
/// Outward faces of VTK's wedge. VTK's valid wedges have the normal of
/// (0, 1, 2) pointing *toward* (3, 4, 5), as checked with VTK 9.7's
/// vtkCellValidator (its documentation says the opposite), like the base of
/// the hexahedron and the prisms.
pub const WEDGE_FACES: [&[u8]; 5] = [
    &[0, 2, 1],
    &[3, 4, 5],
    &[0, 1, 4, 3],
    &[1, 2, 5, 4],
    &[2, 0, 3, 5],
];
/// Outward faces of VTK's hexahedron.
pub const HEXAHEDRON_FACES: [&[u8]; 6] = [
    &[0, 4, 7, 3],
    &[1, 2, 6, 5],
    &[0, 1, 5, 4],
    &[3, 7, 6, 2],
    &[0, 3, 2, 1],
    &[4, 5, 6, 7],
];
/// VTK voxel vertex order mapped onto hexahedron order: `hex[i] = voxel[VOXEL_TO_HEX[i]]`.
pub const VOXEL_TO_HEX: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// Outward faces of VTK's n-gonal prism (bottom `0..n`, top `n..2n`).
pub fn prism_faces(n: u8) -> Vec<Vec<u8>> {
    let mut f = vec![(0..n).rev().collect::<Vec<u8>>(), (n..2 * n).collect()];
    for i in 0..n {
        let j = (i + 1) % n;
        f.push(vec![i, j, j + n, i + n]);
    }
    f
}

/// Meta-cell ids of the built-in types, fixed in every catalog.
pub mod builtin {
    /// Tetrahedron.
    pub const TETRA: u16 = 0;
    /// Pyramid.
    pub const PYRAMID: u16 = 1;
    /// Wedge.
    pub const WEDGE: u16 = 2;
    /// Hexahedron (and voxel).
    pub const HEXAHEDRON: u16 = 3;
}

fn owned(f: &[&[u8]]) -> Vec<Vec<u8>> {
    f.iter().map(|x| x.to_vec()).collect()
}

impl Default for Catalog {
    fn default() -> Self {
        Self::new()
    }
}

impl Catalog {
    /// A catalog with the built-in tetrahedron, pyramid, wedge and hexahedron.
    pub fn new() -> Self {
        let mut c = Catalog {
            metas: Vec::new(),
            ids: HashMap::new(),
        };
        let builtins: [(u8, &str, usize, Vec<Vec<u8>>); 4] = [
            (vtk_type::TETRA, "tetrahedron", 4, owned(&TETRA_FACES)),
            (vtk_type::PYRAMID, "pyramid", 5, owned(&PYRAMID_FACES)),
            (vtk_type::WEDGE, "wedge", 6, owned(&WEDGE_FACES)),
            (
                vtk_type::HEXAHEDRON,
                "hexahedron",
                8,
                owned(&HEXAHEDRON_FACES),
            ),
        ];
        for (t, name, nv, faces) in builtins {
            let m = MetaCell::from_faces(name, nv, faces).expect("built-in meta-cells are valid");
            c.ids.insert(MetaKey::Vtk(t), c.metas.len() as u16);
            c.metas.push(m);
        }
        c.ids
            .insert(MetaKey::Vtk(vtk_type::VOXEL), builtin::HEXAHEDRON);
        c
    }

    /// The meta-cell with id `id`.
    pub fn get(&self, id: u16) -> &MetaCell {
        &self.metas[id as usize]
    }

    /// Id of the meta-cell for a VTK typed cell, generating it on first use
    /// (pentagonal and hexagonal prisms). `None` for unknown types.
    pub fn for_vtk_type(&mut self, t: u8) -> Option<u16> {
        if let Some(&id) = self.ids.get(&MetaKey::Vtk(t)) {
            return Some(id);
        }
        let (name, n) = match t {
            vtk_type::PENTAGONAL_PRISM => ("pentagonal prism", 5),
            vtk_type::HEXAGONAL_PRISM => ("hexagonal prism", 6),
            _ => return None,
        };
        let m = MetaCell::from_faces(name, 2 * n as usize, prism_faces(n))
            .expect("prism faces are valid");
        Some(self.insert(MetaKey::Vtk(t), m))
    }

    /// Id of the meta-cell for a polyhedron with local outward face loops,
    /// generating it on first use of that face structure.
    pub fn for_faces(&mut self, nv: usize, faces: &[Vec<u8>]) -> Result<u16, MetaCellError> {
        let key = MetaKey::Faces(faces.to_vec());
        if let Some(&id) = self.ids.get(&key) {
            return Ok(id);
        }
        let m = MetaCell::from_faces(
            format!("polyhedron({nv}v,{}f)", faces.len()),
            nv,
            faces.to_vec(),
        )?;
        Ok(self.insert(key, m))
    }

    fn insert(&mut self, key: MetaKey, m: MetaCell) -> u16 {
        let id = self.metas.len() as u16;
        self.metas.push(m);
        self.ids.insert(key, id);
        id
    }

    /// Bytes held by all tables.
    pub fn table_bytes(&self) -> usize {
        self.metas.iter().map(|m| m.table_bytes()).sum()
    }
}

impl MetaCell {
    /// Per face, the bit set of its local vertex ids (bit `v` for vertex `v`):
    /// two faces of a cell with distinct vertices have the same vertex set
    /// exactly when their masks are equal.
    pub fn face_masks(&self) -> &[u16] {
        &self.face_masks
    }

    /// Signed volume of a cell of this type (positive for outward faces),
    /// by a fan of tetrahedra from the vertex centroid over triangulated faces.
    /// Exact for planar faces; for warped quads it is the volume of the
    /// polyhedron with the faces split into triangles around their centroid.
    pub fn signed_volume<F: Fn(usize) -> [f64; 3] + ?Sized>(&self, pos: &F) -> f64 {
        let mut pts = [[0.0f64; 3]; MAX_META_VERTICES];
        for (v, p) in pts.iter_mut().enumerate().take(self.nv) {
            *p = pos(v);
        }
        self.signed_volume_of(&mut pts)
    }

    /// [`MetaCell::signed_volume`] of the positions `pts[..nv]` (local vertex
    /// order), which are overwritten (recentred). Same arithmetic in the same
    /// order, so bit-identical; hexahedra take an unrolled loop.
    #[inline]
    pub fn signed_volume_of(&self, pts: &mut [[f64; 3]; MAX_META_VERTICES]) -> f64 {
        // Positions taken relative to the vertex mean c, so that each
        // tetrahedron (c, face centre, a, b) is one determinant.
        let n = self.nv.min(MAX_META_VERTICES);
        let mut c = [0.0; 3];
        for p in &pts[..n] {
            for a in 0..3 {
                c[a] += p[a];
            }
        }
        let inv_n = 1.0 / self.nv as f64;
        for p in &mut pts[..n] {
            for a in 0..3 {
                p[a] -= c[a] * inv_n;
            }
        }
        // One accumulator over all faces, in face order (as before).
        let mut six_vol = 0.0;
        if let Some(faces) = &self.hex_faces {
            for f in faces {
                face_six_volume(pts, f, &mut six_vol);
            }
        } else {
            for f in &self.faces {
                face_six_volume(pts, f, &mut six_vol);
            }
        }
        six_vol / 6.0
    }

    /// The faces as a fixed array when the cell has 8 vertices and 6
    /// quadrilateral faces (the hexahedron).
    pub(crate) fn hex_faces(&self) -> Option<&[[u8; 4]; 6]> {
        self.hex_faces.as_ref()
    }

    /// Six times the signed volume of [`MetaCell::signed_volume_of`]'s
    /// polyhedron (each face split into triangles around its vertex mean),
    /// by a shorter formula: per face its vertex sum dotted with its vector
    /// area (for a quad, the cross product of its diagonals), over the
    /// face's length. Equal in exact arithmetic (the closed surface's volume
    /// does not depend on the origin), not bit for bit: a filter for the
    /// sign, not the value.
    #[inline]
    pub fn six_volume_filter(&self, pts: &[[f64; 3]; MAX_META_VERTICES]) -> f64 {
        let mut six_vol = 0.0;
        if let Some(faces) = &self.hex_faces {
            for f in faces {
                let p = |k: usize| pts[f[k] as usize];
                let (a, b, c, d) = (p(0), p(1), p(2), p(3));
                let s = cross(sub(c, a), sub(d, b));
                let sum = add(add(a, b), add(c, d));
                six_vol += 0.25 * dot(sum, s);
            }
            return six_vol;
        }
        for f in &self.faces {
            let p0 = pts[f[0] as usize];
            let (mut s, mut sum) = ([0.0; 3], p0);
            for w in f[1..].windows(2) {
                let (p, q) = (pts[w[0] as usize], pts[w[1] as usize]);
                let x = cross(sub(p, p0), sub(q, p0));
                for a in 0..3 {
                    s[a] += x[a];
                    sum[a] += p[a];
                }
            }
            let last = pts[f[f.len() - 1] as usize];
            for a in 0..3 {
                sum[a] += last[a];
            }
            six_vol += dot(sum, s) / f.len() as f64;
        }
        six_vol
    }
}

/// Adds to `six_vol`, edge by edge, six times the signed volume of the cone
/// from the origin over one face split into triangles around its vertex mean.
#[inline(always)]
fn face_six_volume(pts: &[[f64; 3]; MAX_META_VERTICES], f: &[u8], six_vol: &mut f64) {
    let mut fc = [0.0; 3];
    for &v in f {
        let p = pts[v as usize];
        for a in 0..3 {
            fc[a] += p[a];
        }
    }
    let inv_k = 1.0 / f.len() as f64;
    let fc = fc.map(|x| x * inv_k);
    let mut prev = pts[*f.last().expect("faces have vertices") as usize];
    for &v in f {
        let cur = pts[v as usize];
        *six_vol += fc[0] * (prev[1] * cur[2] - prev[2] * cur[1])
            - fc[1] * (prev[0] * cur[2] - prev[2] * cur[0])
            + fc[2] * (prev[0] * cur[1] - prev[1] * cur[0]);
        prev = cur;
    }
}
