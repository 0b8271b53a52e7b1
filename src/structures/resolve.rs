//! Cells resolved to meta-cells: each cell's meta-cell id and its vertex
//! ids in the meta-cell's local order (polyhedra get a catalog entry for
//! their face loops). Shared by the CGraph and the corner-point graph.

use std::borrow::Cow;

use crate::grid::{Cells, is_lower_dimensional, vtk_type};
use crate::metacell::{Catalog, MAX_META_VERTICES, VOXEL_TO_HEX};
use crate::structures::StructureError;

/// Meta id of skipped 0D/1D/2D cells (no vertices, no faces stored).
pub(crate) const NON_VOLUMETRIC: u16 = u16::MAX;

/// Resolves each cell to a meta-cell id and its local-order vertex ids
/// (offsets and ids; borrowed from `cells` when every cell is a typed
/// volumetric cell other than a voxel, whose ids are already in local order).
pub(crate) fn resolve_cells<'a>(
    cells: &'a Cells,
    points: &[[f64; 3]],
    catalog: &mut Catalog,
) -> Result<(Vec<u16>, Cow<'a, [u32]>, Cow<'a, [u32]>), StructureError> {
    let n = cells.len();
    if !cells.types.iter().all(|&t| keeps_order(t)) {
        let mut r = Resolver::new(n, cells.connectivity.len());
        for c in 0..n {
            r.push(
                catalog,
                points,
                c,
                cells.types[c],
                cells.cell(c),
                cells.faces_of(c),
            )?;
        }
        let (metas, offsets, verts) = r.finish();
        return Ok((metas, Cow::Owned(offsets), Cow::Owned(verts)));
    }
    let mut metas = Vec::with_capacity(n);
    let mut by_type = [u16::MAX; 256];
    for c in 0..n {
        let t = cells.types[c];
        let m = type_meta(catalog, &mut by_type, c, t)?;
        if cells.cell(c).len() != catalog.get(m).nv {
            return Err(count_mismatch(c));
        }
        metas.push(m);
    }
    Ok((
        metas,
        Cow::Borrowed(&cells.offsets[..]),
        Cow::Borrowed(&cells.connectivity[..]),
    ))
}

/// Whether a cell of VTK type `t` resolves to its own ids in their order
/// (a typed volumetric cell other than a voxel).
fn keeps_order(t: u8) -> bool {
    t != vtk_type::POLYHEDRON && t != vtk_type::VOXEL && !is_lower_dimensional(t)
}

/// The meta-cell of VTK type `t` (cell `c`), looked up once per type.
fn type_meta(
    catalog: &mut Catalog,
    by_type: &mut [u16; 256],
    c: usize,
    t: u8,
) -> Result<u16, StructureError> {
    if by_type[t as usize] == u16::MAX {
        by_type[t as usize] =
            catalog
                .for_vtk_type(t)
                .ok_or_else(|| StructureError::UnsupportedCell {
                    cell: c,
                    why: format!("unsupported VTK cell type {t}"),
                })?;
    }
    Ok(by_type[t as usize])
}

/// Cell `c` has not the vertex count of its type.
fn count_mismatch(c: usize) -> StructureError {
    StructureError::UnsupportedCell {
        cell: c,
        why: "vertex count does not match its type".into(),
    }
}

/// [`resolve_cells`] one cell at a time, into owned offsets and ids: for
/// cells that come from more than one array (the corner-point graph's
/// input cells with the pieces of its split cells in their place).
pub(crate) struct Resolver {
    by_type: [u16; 256],
    metas: Vec<u16>,
    offsets: Vec<u32>,
    verts: Vec<u32>,
}

impl Resolver {
    /// Room for `n` cells with `conn` ids.
    pub(crate) fn new(n: usize, conn: usize) -> Self {
        let mut offsets = Vec::with_capacity(n + 1);
        offsets.push(0);
        Resolver {
            by_type: [u16::MAX; 256],
            metas: Vec::with_capacity(n),
            offsets,
            verts: crate::mem::huge_vec(conn),
        }
    }

    /// Resolves cell `c` (VTK type `t`, point ids `ids`, face stream
    /// `faces` for a polyhedron).
    pub(crate) fn push(
        &mut self,
        catalog: &mut Catalog,
        points: &[[f64; 3]],
        c: usize,
        t: u8,
        ids: &[u32],
        faces: &[u32],
    ) -> Result<(), StructureError> {
        if is_lower_dimensional(t) {
            self.metas.push(NON_VOLUMETRIC);
            self.offsets.push(self.verts.len() as u32);
            return Ok(());
        }
        let m = if t == vtk_type::POLYHEDRON {
            let (local, faces) = polyhedron_local_faces(faces, points)
                .map_err(|why| StructureError::UnsupportedCell { cell: c, why })?;
            let m = catalog.for_faces(local.len(), &faces).map_err(|e| {
                StructureError::UnsupportedCell {
                    cell: c,
                    why: format!("polyhedron: {e}"),
                }
            })?;
            self.verts.extend_from_slice(&local);
            m
        } else {
            let m = type_meta(catalog, &mut self.by_type, c, t)?;
            if t == vtk_type::VOXEL {
                self.verts.extend(VOXEL_TO_HEX.iter().map(|&i| ids[i]));
            } else {
                self.verts.extend_from_slice(ids);
            }
            m
        };
        if self.verts.len() - *self.offsets.last().expect("offsets") as usize != catalog.get(m).nv {
            return Err(count_mismatch(c));
        }
        self.metas.push(m);
        self.offsets.push(self.verts.len() as u32);
        Ok(())
    }

    /// [`Resolver::push`] of `cells`' cells `a..b`, as output cells
    /// `first..`: when all are typed cells that keep their order (no
    /// polyhedron, voxel or 0D–2D cell), their ids are copied in one piece.
    pub(crate) fn push_run(
        &mut self,
        catalog: &mut Catalog,
        points: &[[f64; 3]],
        cells: &Cells,
        (a, b): (usize, usize),
        first: usize,
    ) -> Result<(), StructureError> {
        if !cells.types[a..b].iter().all(|&t| keeps_order(t)) {
            for c in a..b {
                let (t, ids, faces) = (cells.types[c], cells.cell(c), cells.faces_of(c));
                self.push(catalog, points, first + c - a, t, ids, faces)?;
            }
            return Ok(());
        }
        let off = &cells.offsets;
        for c in a..b {
            let t = cells.types[c];
            let m = type_meta(catalog, &mut self.by_type, first + c - a, t)?;
            if (off[c + 1] - off[c]) as usize != catalog.get(m).nv {
                return Err(count_mismatch(first + c - a));
            }
            self.metas.push(m);
        }
        let shift = self.verts.len() as u32;
        let (oa, ob) = (off[a], off[b]);
        self.verts
            .extend_from_slice(&cells.connectivity[oa as usize..ob as usize]);
        self.offsets
            .extend(off[a + 1..=b].iter().map(|&o| o - oa + shift));
        Ok(())
    }

    /// Meta ids, offsets and ids.
    pub(crate) fn finish(self) -> (Vec<u16>, Vec<u32>, Vec<u32>) {
        (self.metas, self.offsets, self.verts)
    }
}

/// Local vertex list (first-appearance order) and local face loops of a
/// polyhedron face stream, each face turned outward: its Newell normal must
/// point away from the cell's vertex centroid (valid for convex cells).
fn polyhedron_local_faces(
    stream: &[u32],
    points: &[[f64; 3]],
) -> Result<(Vec<u32>, Vec<Vec<u8>>), String> {
    let mut local: Vec<u32> = Vec::new();
    let mut faces = Vec::new();
    let nf = *stream.first().ok_or("empty face stream")? as usize;
    let mut p = 1;
    for f in 0..nf {
        let n = *stream.get(p).ok_or(format!("face {f} missing"))? as usize;
        let ids = stream
            .get(p + 1..p + 1 + n)
            .ok_or(format!("face {f} truncated"))?;
        let mut face = Vec::with_capacity(n);
        for &g in ids {
            let i = match local.iter().position(|&x| x == g) {
                Some(i) => i,
                None => {
                    local.push(g);
                    local.len() - 1
                }
            };
            if i >= MAX_META_VERTICES {
                return Err(format!(
                    "polyhedron with more than {MAX_META_VERTICES} vertices needs CIEL (not available yet)"
                ));
            }
            face.push(i as u8);
        }
        faces.push(face);
        p += 1 + n;
    }
    if consistently_oriented(&faces) {
        // Already a closed, consistently oriented surface (e.g. corner-point
        // cells with collapsed edges): keep it; `CGraph::build` flips the
        // whole cell if its volume comes out negative.
        return Ok((local, faces));
    }
    let pt = |l: u8| points[local[l as usize] as usize];
    let mut c = [0.0; 3];
    for &g in &local {
        for a in 0..3 {
            c[a] += points[g as usize][a] / local.len() as f64;
        }
    }
    for face in &mut faces {
        let mut n = [0.0; 3];
        let mut fc = [0.0; 3];
        for i in 0..face.len() {
            let (a, b) = (pt(face[i]), pt(face[(i + 1) % face.len()]));
            n[0] += (a[1] - b[1]) * (a[2] + b[2]);
            n[1] += (a[2] - b[2]) * (a[0] + b[0]);
            n[2] += (a[0] - b[0]) * (a[1] + b[1]);
            for k in 0..3 {
                fc[k] += a[k] / face.len() as f64;
            }
        }
        if n[0] * (fc[0] - c[0]) + n[1] * (fc[1] - c[1]) + n[2] * (fc[2] - c[2]) < 0.0 {
            face.reverse();
        }
    }
    Ok((local, faces))
}

/// True when every directed edge of the face loops is used exactly once and
/// its reverse exactly once (a closed, consistently oriented surface).
fn consistently_oriented(faces: &[Vec<u8>]) -> bool {
    let mut directed: Vec<(u8, u8)> = Vec::new();
    for f in faces {
        for i in 0..f.len() {
            directed.push((f[i], f[(i + 1) % f.len()]));
        }
    }
    directed.sort_unstable();
    if directed.windows(2).any(|w| w[0] == w[1]) {
        return false;
    }
    directed
        .iter()
        .all(|&(a, b)| directed.binary_search(&(b, a)).is_ok())
}
