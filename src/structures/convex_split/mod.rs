//! Non-convex polyhedra split into convex pieces (a star decomposition), so
//! that every structure slices them correctly. No I/O.
//!
//! A polyhedral cell (`VTK_POLYHEDRON`) is *non-convex* when, with its faces
//! oriented outward, some vertex lies more than [`CONVEXITY_TOLERANCE`] ×
//! its extent outside a face plane (the test the CIEL build counts with,
//! read through `polyhedron::polyhedron_faces_in`; non-planar faces are caught too). Such a cell is replaced by
//! pieces coned from one interior point `p` of the cell:
//!
//! - each face that is planar and convex (within tolerance) becomes the base
//!   of one pyramid with apex `p` (a tetrahedron for a triangle, a VTK
//!   pyramid for a quad, a polyhedron otherwise);
//! - each face that is not planar or not convex is first triangulated: a
//!   fan from a new vertex at the face's area centroid (or its vertex mean)
//!   when every fan triangle is positive, else ear clipping; every triangle
//!   coned to `p` gives a tetrahedron. A face shared with a cell that is
//!   live and not split is kept whole instead, so the grid stays conforming.
//!   Faces are triangulated from a canonical loop (smallest id first), so
//!   the two cells sharing a face get the same triangles and the same new
//!   vertex.
//!
//! `p` is the first of the cell's volume centroid, its vertex mean and the
//! mean of the vertices of its kernel (the intersection of the inner
//! half-spaces of its faces and triangles) that is strictly (by
//! [`CONVEXITY_TOLERANCE`] × extent) on the inner side of every base and
//! triangle: the cell is then star-shaped from `p`, and the pieces are
//! convex, have positive volumes and tile the cell. Failing that (thin
//! slivers between warped faces), `p` is the first vertex of the cell that
//! is strictly inside every face it is not on, coned over those faces only
//! (exact for planar faces through `p`). A cell with no such point is an
//! error naming the cell.
//!
//! New vertices (face points, cell points) are appended after the input's
//! points; their point-property values are the means of the face's or the
//! cell's vertices. Every piece records its source cell
//! ([`SplitMap::source`]) and carries its source cell's cell properties.

mod split;
mod twisted;

use std::hash::Hasher;
use std::ops::Deref;

use thiserror::Error;

use crate::cellgraph::{CellGraph, Lattice, Stamp};
use crate::extract::EmitContext;
use crate::field::ScalarField;
use crate::grid::{Cells, Grid, Property};
use crate::metacell::{Catalog, MAX_META_VERTICES};
use crate::structures::polyhedron::CONVEXITY_TOLERANCE;
use split::split_with;

/// A cell that cannot be split into convex pieces.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum SplitError {
    /// No interior point sees every face: the cell is not star-shaped.
    #[error(
        "cell {cell}: non-convex and not star-shaped (no point inside sees all its faces; face {face} is hidden from the best candidate), so it cannot be split into convex pieces"
    )]
    NotStarShaped {
        /// Cell id.
        cell: usize,
        /// A face (index in the cell's face stream) the best candidate point does not see.
        face: usize,
    },
    /// A non-planar or non-convex face that cannot be triangulated.
    #[error(
        "cell {cell}, face {face}: the face cannot be triangulated (self-intersecting or degenerate)"
    )]
    Face {
        /// Cell id.
        cell: usize,
        /// Face index in the cell's face stream.
        face: usize,
    },
    /// Too many points or cells after splitting.
    #[error("grid too large after splitting non-convex cells: {0}")]
    TooLarge(String),
}

/// Counts of a split, reported by `info`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SplitReport {
    /// Non-convex polyhedra found (live, not hidden) and split.
    pub non_convex: usize,
    /// Convex pieces they became.
    pub pieces: usize,
    /// Faces triangulated (non-planar or non-convex faces).
    pub triangulated_faces: usize,
    /// Non-planar or non-convex faces kept whole because the cell across
    /// them is not split (the grid stays conforming).
    pub kept_faces: usize,
    /// New vertices (face points and cell points).
    pub new_vertices: usize,
    /// Cells with no interior star point, coned from one of their vertices
    /// over the faces it is not on (slivers).
    pub vertex_pulled: usize,
    /// Typed cells with a face that crosses itself (twisted), not hidden,
    /// sliced through their decomposition coned from the vertex mean.
    pub twisted: usize,
    /// Hidden twisted cells, cut alike (their pieces are hidden).
    pub twisted_hidden: usize,
    /// Pieces (tetrahedra and pyramids) the twisted cells became.
    pub twisted_pieces: usize,
    /// The first twisted cells (input ids, ascending, at most 20).
    pub twisted_first: Vec<usize>,
    /// Non-convex cells that cannot be split (a face that cannot be
    /// triangulated, or no star point): skipped, not sliced.
    pub skipped: usize,
    /// The first skipped cells (input ids, ascending, at most 20).
    pub skipped_first: Vec<usize>,
    /// Why the first skipped cell was skipped.
    pub skipped_reason: String,
}

/// How a split grid maps back to its input.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplitMap {
    /// Per output cell, the input cell it comes from.
    pub source: Vec<u32>,
    /// Per input cell, true when it was split into pieces.
    pub is_split: Vec<bool>,
    /// Points of the input grid (new vertices are numbered from here).
    pub input_points: usize,
    /// Cells of the input grid.
    pub input_cells: usize,
    /// New vertex `i` is the mean of input vertices
    /// `mean_ids[mean_offsets[i]..mean_offsets[i + 1]]`.
    pub mean_offsets: Vec<u32>,
    /// See [`SplitMap::mean_offsets`].
    pub mean_ids: Vec<u32>,
    /// Counts.
    pub report: SplitReport,
}

impl SplitMap {
    /// The hidden flags of the output cells (each piece as its input cell),
    /// as the split grid's own `vtkGhostType` would give them.
    pub fn hidden_cells(&self, hidden: Option<&[bool]>) -> Option<Vec<bool>> {
        let h = hidden?;
        Some(
            self.source
                .iter()
                .map(|&s| h.get(s as usize).copied().unwrap_or(false))
                .collect(),
        )
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.source.len() * 4
            + self.is_split.len()
            + (self.mean_offsets.len() + self.mean_ids.len()) * 4
    }

    /// Per-vertex values of the split grid from per-vertex values of the
    /// input (new vertices get the mean of their recipe).
    pub fn extend_vertex_values(&self, input: &[f64]) -> Vec<f64> {
        let mut out = Vec::with_capacity(input.len() + self.mean_offsets.len() - 1);
        out.extend_from_slice(input);
        for w in self.mean_offsets.windows(2) {
            let ids = &self.mean_ids[w[0] as usize..w[1] as usize];
            out.push(ids.iter().map(|&v| input[v as usize]).sum::<f64>() / ids.len() as f64);
        }
        out
    }

    /// Per-cell values of the split grid (each piece takes its source's value).
    pub fn per_output_cell(&self, input: &[f64]) -> Vec<f64> {
        self.source
            .iter()
            .map(|&c| input.get(c as usize).copied().unwrap_or(0.0))
            .collect()
    }
}

/// Where a split cell's pieces meet.
enum Star {
    /// A new interior point.
    Apex(P3),
    /// One of the cell's vertices (its faces through it get no piece).
    Vertex(u32),
}

/// The `k`-tuples `values[s]` for `s` in `source` (which is non-decreasing:
/// runs of consecutive cells), copied a run at a time.
fn gather_tuples(source: &[u32], values: &[f64], k: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(source.len() * k);
    let mut i = 0;
    while i < source.len() {
        let s0 = source[i] as usize;
        let mut j = i + 1;
        while j < source.len() && source[j] as usize == s0 + (j - i) {
            j += 1;
        }
        out.extend_from_slice(&values[s0 * k..(s0 + j - i) * k]);
        i = j;
    }
    out
}

/// A grid whose non-convex polyhedra were split, with its map to the input.
#[derive(Clone, Debug)]
pub struct SplitGrid {
    /// The split grid.
    pub grid: Grid,
    /// Output → input.
    pub map: SplitMap,
}

/// The pieces of a split without the split grid: what the corner-point
/// graph reads, taking the cells that are not split from the input.
#[derive(Clone, Debug)]
pub struct SplitPieces {
    /// The pieces of the split cells: split cell by split cell, in cell
    /// order, each cell's pieces as the split grid orders them (output
    /// cell `o` with `map.is_split[map.source[o]]` is the next piece here).
    pub cells: Cells,
    /// The input's points, then the new vertices (the split grid's points).
    pub points: Vec<P3>,
    /// Output (split grid) → input.
    pub map: SplitMap,
}

/// A sweep structure built on a split grid (or on the input when nothing
/// was split): derefs to the structure; as a [`CellGraph`] it reports
/// input cell ids from [`CellGraph::source_cell`].
#[derive(Clone, Debug)]
pub struct Split<T> {
    /// The structure, built on the split grid.
    pub inner: T,
    /// The split, `None` when the input had no non-convex polyhedron.
    pub map: Option<SplitMap>,
}

impl<T> Deref for Split<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.inner
    }
}

impl<T> From<T> for Split<T> {
    /// A structure on a grid with nothing split.
    fn from(inner: T) -> Self {
        Split { inner, map: None }
    }
}

impl<T> Split<T> {
    /// Input cell id of output cell `c`.
    #[inline(always)]
    pub fn source_of(&self, c: u32) -> u32 {
        match &self.map {
            Some(m) => m.source[c as usize],
            None => c,
        }
    }
}

impl<T: CellGraph> CellGraph for Split<T> {
    #[inline(always)]
    fn slot_count(&self) -> usize {
        self.inner.slot_count()
    }
    #[inline(always)]
    fn is_live(&self, slot: u32) -> bool {
        self.inner.is_live(slot)
    }
    fn initial_stamps(&self) -> Vec<Stamp> {
        self.inner.initial_stamps()
    }
    #[inline(always)]
    fn catalog(&self) -> &Catalog {
        self.inner.catalog()
    }
    #[inline(always)]
    fn positions(&self) -> &[[f32; 3]] {
        self.inner.positions()
    }
    #[inline(always)]
    fn cell(&self, slot: u32, out: &mut [u32; MAX_META_VERTICES]) -> (u16, usize) {
        self.inner.cell(slot, out)
    }
    #[inline(always)]
    fn for_each_neighbour(&self, slot: u32, f: impl FnMut(u32)) {
        self.inner.for_each_neighbour(slot, f)
    }
    #[inline(always)]
    fn scan_neighbours<F: ScalarField>(
        &self,
        f: &F,
        slot: u32,
        ids: &[u32; MAX_META_VERTICES],
        phi: &[f32; MAX_META_VERTICES],
        want: impl FnMut(u32) -> bool,
        found: impl FnMut(u32, f32),
    ) {
        self.inner.scan_neighbours(f, slot, ids, phi, want, found)
    }
    #[inline(always)]
    fn prefetch_cell(&self, slot: u32, ctx: &EmitContext) {
        self.inner.prefetch_cell(slot, ctx)
    }
    #[inline(always)]
    fn source_cell(&self, slot: u32) -> u32 {
        self.source_of(self.inner.source_cell(slot))
    }
    fn lattice(&self) -> Option<Lattice<'_>> {
        self.inner.lattice()
    }
    fn blocks(&self, n: usize) -> Vec<(u32, u32)> {
        self.inner.blocks(n)
    }
}

/// Newell normal (twice the vector area) of a loop of points.
pub fn newell(pts: &[[f64; 3]]) -> [f64; 3] {
    newell_by(pts.len(), |i| pts[i])
}

/// [`newell`] of the loop `pt(0), …, pt(len − 1)` (same arithmetic).
#[inline]
fn newell_by(len: usize, pt: impl Fn(usize) -> [f64; 3]) -> [f64; 3] {
    let mut n = [0.0; 3];
    for i in 0..len {
        let (a, b) = (pt(i), pt((i + 1) % len));
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    n
}

use crate::vec3::{P3, add, cross, dot, mean, norm, scale, sub};

/// A face loop rotated to start at its smallest id, in the direction whose
/// second vertex is the smaller neighbour; and whether `face` runs in that
/// direction.
#[cfg(test)]
fn canonical(face: &[u32]) -> (Vec<u32>, bool) {
    let (i0, same) = canonical_start(face);
    let n = face.len();
    (
        (0..n).map(|k| canonical_at(face, i0, same, k)).collect(),
        same,
    )
}

/// Where [`canonical`]'s loop starts in `face`, and whether it runs in
/// `face`'s direction (without building it).
fn canonical_start(face: &[u32]) -> (usize, bool) {
    let n = face.len();
    let i0 = (0..n).min_by_key(|&i| face[i]).unwrap_or(0);
    (i0, face[(i0 + 1) % n] < face[(i0 + n - 1) % n])
}

/// Vertex `k` of [`canonical`]'s loop, from [`canonical_start`]'s answer.
#[inline]
fn canonical_at(face: &[u32], i0: usize, same: bool, k: usize) -> u32 {
    let n = face.len();
    if same {
        face[(i0 + k) % n]
    } else {
        face[(i0 + n - k) % n]
    }
}

/// How a face is cut into triangles (on its canonical loop).
#[derive(Clone, Debug)]
enum FacePlan {
    /// Kept whole: the base of one pyramid.
    Whole,
    /// Fan from a new vertex (output point id) at the given position.
    Fan(u32),
    /// Ear-clipping triangles (canonical orientation).
    Ears(Vec<[u32; 3]>),
    /// No triangulation (self-intersecting or degenerate): the split cells
    /// with this face are skipped.
    Failed,
}

/// A face's unit Newell normal, vertex mean and tolerance
/// ([`CONVEXITY_TOLERANCE`] × its radius about the mean); `None` when the
/// normal is zero.
fn face_frame(pts: &[P3]) -> Option<(P3, P3, f64)> {
    let n = newell(pts);
    let ln = norm(n);
    if ln == 0.0 {
        return None;
    }
    let m = mean(pts.iter().copied());
    let ext = pts.iter().map(|&p| norm(sub(p, m))).fold(0.0, f64::max);
    Some((scale(n, 1.0 / ln), m, CONVEXITY_TOLERANCE * ext))
}

/// Is the canonical face non-planar or non-convex (beyond tolerance)?
fn face_is_bad(pts: &[P3]) -> bool {
    if pts.len() <= 3 {
        return false;
    }
    let Some((nh, m, tol)) = face_frame(pts) else {
        return true;
    };
    let k = pts.len();
    (0..k).any(|i| {
        let (a, b, c) = (pts[(i + k - 1) % k], pts[i], pts[(i + 1) % k]);
        let chord = norm(sub(c, a));
        dot(sub(b, m), nh).abs() > tol
            || (chord > 0.0 && dot(cross(sub(b, a), sub(c, b)), nh) / chord < -tol)
    })
}

/// A point `q` from which every edge of the face is seen positively
/// (the fan triangles `(q, a, b)` are positive along the face normal):
/// the area centroid, else the vertex mean.
fn fan_point(pts: &[P3]) -> Option<P3> {
    let (nh, m, tol) = face_frame(pts)?;
    let k = pts.len();
    let mut area = 0.0;
    let mut acc = [0.0; 3];
    for i in 0..k {
        let (a, b) = (pts[i], pts[(i + 1) % k]);
        let w = dot(cross(sub(a, m), sub(b, m)), nh);
        area += w;
        acc = add(acc, scale(add(add(a, b), m), w / 3.0));
    }
    let centroid = scale(acc, 1.0 / area);
    [centroid, m].into_iter().find(|&q| {
        q.iter().all(|x| x.is_finite())
            && (0..k).all(|i| {
                let (a, b) = (pts[i], pts[(i + 1) % k]);
                let e = norm(sub(b, a));
                e > 0.0 && dot(cross(sub(a, q), sub(b, q)), nh) / e > tol
            })
    })
}

/// Ear clipping of a (possibly slightly non-planar) simple polygon, in the
/// plane of its Newell normal; triangles keep the loop's orientation.
fn ear_clip(ids: &[u32], pts: &[P3]) -> Option<Vec<[u32; 3]>> {
    let (nh, m, tol) = face_frame(pts)?;
    // Twice a triangle's area against tolerance × radius².
    let tol = tol * pts.iter().map(|&p| norm(sub(p, m))).fold(0.0, f64::max);
    let area2 =
        |a: usize, b: usize, c: usize| dot(cross(sub(pts[b], pts[a]), sub(pts[c], pts[a])), nh);
    let mut left: Vec<usize> = (0..ids.len()).collect();
    let mut tris = Vec::with_capacity(ids.len() - 2);
    while left.len() > 3 {
        let k = left.len();
        let ear = (0..k).find(|&i| {
            let (a, b, c) = (left[(i + k - 1) % k], left[i], left[(i + 1) % k]);
            if area2(a, b, c) <= tol {
                return false;
            }
            // No other remaining vertex inside (or on) the triangle.
            left.iter().all(|&x| {
                x == a
                    || x == b
                    || x == c
                    || area2(a, b, x) < -tol
                    || area2(b, c, x) < -tol
                    || area2(c, a, x) < -tol
            })
        })?;
        let (a, b, c) = (left[(ear + k - 1) % k], left[ear], left[(ear + 1) % k]);
        tris.push([ids[a], ids[b], ids[c]]);
        left.remove(ear);
    }
    if area2(left[0], left[1], left[2]) <= tol {
        return None;
    }
    tris.push([ids[left[0]], ids[left[1]], ids[left[2]]]);
    Some(tris)
}

/// One element of a cell's boundary after triangulation, oriented outward.
enum Element<'a> {
    /// A whole face (global ids), the base of a pyramid.
    Base(&'a [u32]),
    /// A triangle (global ids, possibly new vertices).
    Tri([u32; 3]),
}

/// Plane of an element: (point on it, unit outward normal).
fn element_plane(e: &Element, pos: &impl Fn(u32) -> P3) -> Option<(P3, P3)> {
    let (c, n) = match e {
        Element::Base(ids) => (
            mean(ids.iter().map(|&v| pos(v))),
            newell_by(ids.len(), |i| pos(ids[i])),
        ),
        Element::Tri([a, b, c]) => {
            let (a, b, c) = (pos(*a), pos(*b), pos(*c));
            (a, cross(sub(b, a), sub(c, a)))
        }
    };
    let l = norm(n);
    (l > 0.0).then(|| (c, scale(n, 1.0 / l)))
}

/// Signed volume of the cone from `p` over an element (positive inside).
fn cone_volume(e: &Element, p: P3, pos: &impl Fn(u32) -> P3) -> f64 {
    let tri = |a: P3, b: P3, c: P3| dot(sub(a, p), cross(sub(b, p), sub(c, p))) / 6.0;
    match e {
        Element::Base(ids) => {
            let a = pos(ids[0]);
            (1..ids.len() - 1)
                .map(|i| tri(a, pos(ids[i]), pos(ids[i + 1])))
                .sum()
        }
        Element::Tri([a, b, c]) => tri(pos(*a), pos(*b), pos(*c)),
    }
}

/// Mean of the vertices of `{x : (x − c_i)·n_i ≤ −margin}` (by enumerating
/// plane triples), or `None` when it is empty or too large to enumerate.
fn kernel_point(planes: &[(P3, P3)], margin: f64, slack: f64) -> Option<P3> {
    let m = planes.len();
    if m > 160 {
        return None;
    }
    let off: Vec<f64> = planes.iter().map(|(c, n)| dot(*c, *n) - margin).collect();
    let mut sum = [0.0; 3];
    let mut count = 0usize;
    for i in 0..m {
        for j in i + 1..m {
            let nij = cross(planes[i].1, planes[j].1);
            for k in j + 1..m {
                let det = dot(nij, planes[k].1);
                if det.abs() < 1e-12 {
                    continue;
                }
                // Cramer: x = (d_i (n_j × n_k) + d_j (n_k × n_i) + d_k (n_i × n_j)) / det.
                let x = scale(
                    add(
                        add(
                            scale(cross(planes[j].1, planes[k].1), off[i]),
                            scale(cross(planes[k].1, planes[i].1), off[j]),
                        ),
                        scale(nij, off[k]),
                    ),
                    1.0 / det,
                );
                if (0..m).all(|l| dot(x, planes[l].1) <= off[l] + slack) {
                    sum = add(sum, x);
                    count += 1;
                }
            }
        }
    }
    (count > 0).then(|| scale(sum, 1.0 / count as f64))
}

/// Multiplicative hasher for small keys of vertex ids (the face table's
/// sorted id lists): much cheaper than SipHash, and the keys are not
/// adversarial.
#[derive(Default)]
pub(super) struct IdsHasher(u64);

impl Hasher for IdsHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            self.write_u64(u64::from_le_bytes(c.try_into().expect("8 bytes")));
        }
        for &b in chunks.remainder() {
            self.write_u64(b as u64);
        }
    }
    fn write_u32(&mut self, x: u32) {
        self.write_u64(x as u64);
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

/// The shared face table of a split: per canonical face (sorted ids), how
/// many split cells use it and how it is cut.
struct FaceTable {
    split_uses: Vec<u8>,
    plan: Vec<Option<FacePlan>>,
}

/// Splits every live, non-hidden, non-convex polyhedron of `grid` into
/// convex pieces (see the module docs). `Ok(None)` when there is none.
/// Polyhedra the CIEL checks reject (open, non-manifold...) are left as
/// they are, for the structure build to report.
pub fn split_non_convex(
    grid: &Grid,
    hidden: Option<&[bool]>,
) -> Result<Option<SplitGrid>, SplitError> {
    split_with(grid, hidden, true, false)
}

/// [`split_non_convex`] without the properties: the split grid has no
/// point or cell data (the sweep structures read only points and cells;
/// properties go through [`SplitMap`]), so nothing is gathered for them.
pub fn split_non_convex_cells(
    grid: &Grid,
    hidden: Option<&[bool]>,
) -> Result<Option<SplitGrid>, SplitError> {
    split_with(grid, hidden, false, false)
}

/// [`split_non_convex_cells`] that also cuts twisted typed cells (a face
/// that crosses itself) into their decomposition coned from the vertex
/// mean (see the `twisted` module): what the structures build on when
/// their classification finds such cells.
pub fn split_non_convex_and_twisted_cells(
    grid: &Grid,
    hidden: Option<&[bool]>,
) -> Result<Option<SplitGrid>, SplitError> {
    split_with(grid, hidden, false, true)
}

/// [`split_non_convex_cells`] without the split grid: the pieces only,
/// the points and the map, so that nothing is copied for the cells that are
/// not split. `Ok(None)` when there is no non-convex polyhedron.
pub fn split_non_convex_pieces(
    grid: &Grid,
    hidden: Option<&[bool]>,
) -> Result<Option<SplitPieces>, SplitError> {
    split::split_pieces(grid, hidden, false)
}

/// [`split_non_convex_pieces`] with the twisted typed cells cut too (see
/// [`split_non_convex_and_twisted_cells`]).
pub fn split_non_convex_and_twisted_pieces(
    grid: &Grid,
    hidden: Option<&[bool]>,
) -> Result<Option<SplitPieces>, SplitError> {
    split::split_pieces(grid, hidden, true)
}

/// A point property with values for the new vertices (component-wise means).
fn extend_point_property(p: &Property, map: &SplitMap) -> Property {
    let k = p.components.max(1);
    let mut values = p.values.clone();
    for w in map.mean_offsets.windows(2) {
        let ids = &map.mean_ids[w[0] as usize..w[1] as usize];
        for comp in 0..k {
            let s: f64 = ids.iter().map(|&v| p.values[v as usize * k + comp]).sum();
            values.push(s / ids.len() as f64);
        }
    }
    Property {
        name: p.name.clone(),
        components: p.components,
        values,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The previous `canonical`: the loop rotated to its smallest id, in
    /// the direction of the smaller neighbour, built both ways.
    fn canonical_reference(face: &[u32]) -> (Vec<u32>, bool) {
        let n = face.len();
        let i0 = (0..n).min_by_key(|&i| face[i]).unwrap_or(0);
        let fwd: Vec<u32> = (0..n).map(|k| face[(i0 + k) % n]).collect();
        if fwd[1] < fwd[n - 1] {
            (fwd, true)
        } else {
            ((0..n).map(|k| face[(i0 + n - k) % n]).collect(), false)
        }
    }

    /// `canonical_start` + `canonical_at` (the split's per-cell pass builds
    /// no loop) give the reference loop and direction on random loops of
    /// distinct ids, both orientations.
    #[test]
    fn canonical_without_a_loop_equals_the_reference() {
        let mut state = 0x1234_5678_9abc_def1u64;
        let mut next = move |m: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % m
        };
        let mut reversed = 0;
        for _ in 0..5000 {
            let n = 3 + next(10) as usize;
            let mut face: Vec<u32> = Vec::new();
            while face.len() < n {
                let v = next(1000) as u32;
                if !face.contains(&v) {
                    face.push(v);
                }
            }
            let (want, dir) = canonical_reference(&face);
            let (i0, same) = canonical_start(&face);
            let got: Vec<u32> = (0..n).map(|k| canonical_at(&face, i0, same, k)).collect();
            assert_eq!((got, same), (want.clone(), dir), "{face:?}");
            assert_eq!(canonical(&face), (want, dir));
            reversed += !dir as usize;
        }
        assert!(reversed > 1000 && reversed < 4000, "{reversed} reversed");
    }
}
