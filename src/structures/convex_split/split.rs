//! The split's passes: find the non-convex polyhedra, share their faces in
//! one table, plan each face (whole, fan, ears), find each cell's star
//! point in parallel, cut the cells into pieces, then assemble the output
//! grid and carry the properties over.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

use super::twisted::{find_twisted, twisted_pieces};
use super::{
    Element, FacePlan, FaceTable, IdsHasher, SplitError, SplitGrid, SplitMap, SplitPieces,
    SplitReport, Star, canonical_at, canonical_start, cone_volume, ear_clip, element_plane,
    extend_point_property, face_is_bad, fan_point, gather_tuples, kernel_point,
};
use crate::grid::{Cells, Grid, Property, Topology, is_lower_dimensional, vtk_type};
use crate::structures::is_sweepable;
use crate::structures::polyhedron::{CONVEXITY_TOLERANCE, Scratch, polyhedron_faces_in};
use crate::vec3::{P3, add, cross, dot, mean, norm, scale, sub};

/// A non-convex polyhedron to split: its cell and its faces, oriented
/// outward.
type Found = (usize, FaceLoops);

/// A cell's face loops (global ids), concatenated: face `f` is
/// `ids[starts[f]..starts[f + 1]]`.
struct FaceLoops {
    ids: Vec<u32>,
    starts: Vec<u32>,
}

impl FaceLoops {
    /// Faces.
    fn len(&self) -> usize {
        self.starts.len() - 1
    }
    /// Face `f`'s loop.
    fn get(&self, f: usize) -> &[u32] {
        &self.ids[self.starts[f] as usize..self.starts[f + 1] as usize]
    }
    /// The loops in face order.
    fn iter(&self) -> impl Iterator<Item = &[u32]> {
        (0..self.len()).map(|f| self.get(f))
    }
}

/// A split cell's boundary elements (with the face each comes from), its
/// vertices, and where its pieces meet.
type CellStar<'a> = (Vec<(usize, Element<'a>)>, Vec<u32>, Star);

/// The pieces of the split cells, flat: per split cell (cell order) its
/// cell and its pieces `first[i]..first[i + 1]`; per piece its VTK type
/// and ids `ids[starts[p]..starts[p + 1]]`.
struct Pieces {
    cells: Vec<usize>,
    first: Vec<u32>,
    types: Vec<u8>,
    starts: Vec<u32>,
    ids: Vec<u32>,
}

impl Default for Pieces {
    fn default() -> Self {
        Pieces {
            cells: Vec::new(),
            first: vec![0],
            types: Vec::new(),
            starts: vec![0],
            ids: Vec::new(),
        }
    }
}

impl Pieces {
    /// Closes the current cell's pieces as those of input cell `c`.
    fn end_cell(&mut self, c: usize) {
        self.cells.push(c);
        self.first.push(self.types.len() as u32);
    }
    /// Both lists' cells in cell order (`self` and `other` hold distinct
    /// cells, each in cell order).
    fn merge(self, other: Pieces) -> Pieces {
        if other.cells.is_empty() {
            return self;
        }
        if self.cells.is_empty() {
            return other;
        }
        let mut out = Pieces::default();
        let (mut i, mut j) = (0, 0);
        while i < self.cells.len() || j < other.cells.len() {
            let take_self =
                j == other.cells.len() || (i < self.cells.len() && self.cells[i] < other.cells[j]);
            let (from, k) = if take_self {
                i += 1;
                (&self, i - 1)
            } else {
                j += 1;
                (&other, j - 1)
            };
            let (c, pieces) = from.of(k);
            for (t, ids) in pieces {
                out.push(t, ids);
            }
            out.end_cell(c);
        }
        out
    }
    /// Appends a piece of the current cell.
    fn push(&mut self, t: u8, ids: &[u32]) {
        self.types.push(t);
        self.ids.extend_from_slice(ids);
        self.starts.push(self.ids.len() as u32);
    }
    /// Split cell `i`'s cell and its pieces as (type, ids).
    fn of(&self, i: usize) -> (usize, impl Iterator<Item = (u8, &[u32])>) {
        let r = self.first[i] as usize..self.first[i + 1] as usize;
        (
            self.cells[i],
            r.map(|p| {
                let ids = &self.ids[self.starts[p] as usize..self.starts[p + 1] as usize];
                (self.types[p], ids)
            }),
        )
    }
}

/// The new vertices of a split: positions, and per vertex the input
/// vertices whose mean gives its point-property values.
#[derive(Default)]
struct NewPoints {
    points: Vec<P3>,
    mean_offsets: Vec<u32>,
    mean_ids: Vec<u32>,
}

impl NewPoints {
    /// Appends a new vertex, the mean of `ids`.
    fn push(&mut self, p: P3, ids: &[u32]) {
        self.points.push(p);
        self.mean_ids.extend_from_slice(ids);
        self.mean_offsets.push(self.mean_ids.len() as u32);
    }
}

/// What a split made, before any output grid: the pieces of the split
/// cells, the new vertices, which input cells were split and the counts.
struct Parts<'a> {
    cells: &'a Cells,
    pieces: Pieces,
    new: NewPoints,
    split: Vec<bool>,
    report: SplitReport,
}

impl Parts<'_> {
    /// The map to the input, with `source` per output cell.
    fn into_map(self, source: Vec<u32>, np0: usize) -> (SplitMap, Vec<P3>) {
        let map = SplitMap {
            source,
            is_split: self.split,
            input_points: np0,
            input_cells: self.cells.len(),
            mean_offsets: self.new.mean_offsets,
            mean_ids: self.new.mean_ids,
            report: self.report,
        };
        (map, self.new.points)
    }
}

/// [`super::split_non_convex`], with the point and cell data carried over
/// when `properties` is set.
pub(super) fn split_with(
    grid: &Grid,
    hidden: Option<&[bool]>,
    properties: bool,
    twisted: bool,
) -> Result<Option<SplitGrid>, SplitError> {
    let Some(parts) = split_parts(grid, hidden, twisted)? else {
        return Ok(None);
    };
    let points = &grid.points;
    let np0 = points.len();
    let (out, source) = assemble(parts.cells, &parts.pieces)?;
    let (map, new_points) = parts.into_map(source, np0);
    let mut all_points = Vec::with_capacity(np0 + new_points.len());
    all_points.extend_from_slice(points);
    all_points.extend_from_slice(&new_points);
    let (point_data, cell_data) = if properties {
        carry_properties(grid, &map)
    } else {
        (Vec::new(), Vec::new())
    };
    Ok(Some(SplitGrid {
        grid: Grid {
            points: all_points,
            topology: Topology::Unstructured(out),
            point_data,
            cell_data,
        },
        map,
    }))
}

/// [`super::split_non_convex_pieces`].
pub(super) fn split_pieces(
    grid: &Grid,
    hidden: Option<&[bool]>,
    twisted: bool,
) -> Result<Option<SplitPieces>, SplitError> {
    let Some(parts) = split_parts(grid, hidden, twisted)? else {
        return Ok(None);
    };
    let (n, split_cells) = (parts.cells.len(), parts.pieces.cells.len());
    let out_cells = n - split_cells + parts.pieces.types.len();
    if out_cells >= u32::MAX as usize {
        return Err(SplitError::TooLarge(format!("{out_cells} cells")));
    }
    let mut cells = Cells {
        types: Vec::with_capacity(parts.pieces.types.len()),
        offsets: vec![0],
        connectivity: Vec::with_capacity(parts.pieces.ids.len()),
        face_offsets: vec![0],
        face_stream: Vec::new(),
    };
    let mut source = Vec::with_capacity(out_cells);
    let mut done = 0;
    for i in 0..split_cells {
        let (c, pieces) = parts.pieces.of(i);
        source.extend(done as u32..c as u32);
        for (t, ids) in pieces {
            push_piece(&mut cells, t, ids);
            source.push(c as u32);
        }
        done = c + 1;
    }
    source.extend(done as u32..n as u32);
    let np0 = grid.points.len();
    let (map, new_points) = parts.into_map(source, np0);
    let mut points = crate::mem::huge_vec(np0 + new_points.len());
    points.extend_from_slice(&grid.points);
    points.extend_from_slice(&new_points);
    Ok(Some(SplitPieces { cells, points, map }))
}

/// The passes of a split up to its pieces (see the module docs); with
/// `twisted`, typed cells with a self-crossing face are cut too
/// ([`super::twisted`]). `None` when there is nothing to split.
fn split_parts<'a>(
    grid: &'a Grid,
    hidden: Option<&[bool]>,
    twisted: bool,
) -> Result<Option<Parts<'a>>, SplitError> {
    let Topology::Unstructured(cells) = &grid.topology else {
        return Ok(None);
    };
    let points = &grid.points;
    let is_hidden = |c: usize| hidden.is_some_and(|h| h.get(c).copied().unwrap_or(false));
    let found = if cells.types.contains(&vtk_type::POLYHEDRON) {
        find_non_convex(cells, points, &is_hidden)
    } else {
        Vec::new()
    };
    let twisted = if twisted {
        find_twisted(cells, points)
    } else {
        Vec::new()
    };
    if found.is_empty() && twisted.is_empty() {
        return Ok(None);
    }
    let n = cells.len();
    let mut split = vec![false; n];
    for (c, _) in &found {
        split[*c] = true;
    }
    let mut report = SplitReport {
        non_convex: found.len(),
        ..Default::default()
    };
    let mut new = NewPoints {
        mean_offsets: vec![0],
        ..Default::default()
    };
    let np0 = points.len();
    let mut pieces = if found.is_empty() {
        Pieces::default()
    } else {
        let (mut table, face_ids) = FaceTable::build(&found);
        let ctx = PlanContext {
            cells,
            points,
            split: &split,
            is_hidden: &is_hidden,
        };
        ctx.plan_faces(&found, &face_ids, &mut table, &mut new, &mut report);
        // Cells: boundary elements and star point, per cell in parallel
        // (they read only the cell, its faces' plans and the face points
        // made above); then, in cell order, apex ids and pieces.
        let fan_points = &new.points;
        let cpos = |v: u32| -> P3 {
            if (v as usize) < np0 {
                points[v as usize]
            } else {
                fan_points[v as usize - np0]
            }
        };
        let stars: Vec<Result<CellStar, SplitError>> = found
            .par_iter()
            .zip(face_ids.par_iter())
            .map(|((c, faces), ids)| cell_star(*c, faces, ids, &table, points, &cpos))
            .collect();
        cut_cells(&found, stars, np0, &mut new, &mut report)
    };
    if !twisted.is_empty() {
        let pos = |v: u32| points[v as usize];
        let mut t = Pieces::default();
        for (c, ids, faces) in &twisted {
            split[*c] = true;
            let apex_id = (np0 + new.points.len()) as u32;
            let (apex, recipe, cut) = twisted_pieces(ids, faces, apex_id, &pos);
            new.push(apex, &recipe);
            for (ty, p) in cut {
                t.push(ty, &p);
                report.twisted_pieces += 1;
            }
            t.end_cell(*c);
            if is_hidden(*c) {
                report.twisted_hidden += 1;
            } else {
                report.twisted += 1;
                if report.twisted_first.len() < FIRST_IDS {
                    report.twisted_first.push(*c);
                }
            }
        }
        pieces = pieces.merge(t);
    }
    report.new_vertices = new.points.len();
    if np0 + new.points.len() >= u32::MAX as usize / 4 {
        return Err(SplitError::TooLarge(format!(
            "{} points",
            np0 + new.points.len()
        )));
    }
    Ok(Some(Parts {
        cells,
        pieces,
        new,
        split,
        report,
    }))
}

/// How many cell ids a [`SplitReport`] lists.
const FIRST_IDS: usize = 20;

/// Non-convex polyhedra, with their faces oriented outward (CIEL's
/// build_cell), in cell order. The polyhedra are listed first, then
/// checked in parallel chunks with one scratch each: a per-item rayon
/// folder would move the scratch (some 600 bytes) twice for every cell
/// of the grid, polyhedron or not.
fn find_non_convex(
    cells: &Cells,
    points: &[P3],
    is_hidden: &(dyn Fn(usize) -> bool + Sync),
) -> Vec<Found> {
    let polyhedra: Vec<usize> = (0..cells.len())
        .filter(|&c| cells.types[c] == vtk_type::POLYHEDRON && !is_hidden(c))
        .collect();
    polyhedra
        .par_chunks(256)
        .flat_map_iter(|chunk| {
            let mut s = Scratch::default();
            chunk.iter().filter_map(move |&c| {
                let (class, _, non_convex) =
                    polyhedron_faces_in(c, cells.faces_of(c), points, &mut s).ok()?;
                (is_sweepable(class) && non_convex).then(|| {
                    let faces = FaceLoops {
                        ids: s.ids.clone(),
                        starts: s.starts.clone(),
                    };
                    (c, faces)
                })
            })
        })
        .collect()
}

impl FaceTable {
    /// The canonical faces of the split cells, and per split cell its
    /// faces' entries in the table (one lookup per face). The entries'
    /// sorted ids are kept in one array and found by their hash, chained
    /// through the entries with the same hash: no key is allocated.
    fn build(found: &[Found]) -> (Self, Vec<Vec<usize>>) {
        const NONE: u32 = u32::MAX;
        let mut table = FaceTable {
            split_uses: Vec::new(),
            plan: Vec::new(),
        };
        let mut keys: Vec<u32> = Vec::new();
        let mut key_start: Vec<u32> = vec![0];
        let mut by_hash: HashMap<u64, u32, BuildHasherDefault<IdsHasher>> = HashMap::default();
        let mut same_hash: Vec<u32> = Vec::new();
        let mut k: Vec<u32> = Vec::new();
        let face_ids: Vec<Vec<usize>> = found
            .iter()
            .map(|(_, faces)| {
                faces
                    .iter()
                    .map(|f| {
                        k.clear();
                        k.extend_from_slice(f);
                        k.sort_unstable();
                        let mut hs = IdsHasher::default();
                        hs.write_usize(k.len());
                        k.iter().for_each(|&v| hs.write_u32(v));
                        let h = hs.finish();
                        let h = h ^ (h >> 32);
                        let key = |e: u32| {
                            &keys
                                [key_start[e as usize] as usize..key_start[e as usize + 1] as usize]
                        };
                        let mut e = by_hash.get(&h).copied().unwrap_or(NONE);
                        while e != NONE && key(e) != &k[..] {
                            e = same_hash[e as usize];
                        }
                        if e == NONE {
                            e = table.split_uses.len() as u32;
                            same_hash.push(by_hash.insert(h, e).unwrap_or(NONE));
                            keys.extend_from_slice(&k);
                            key_start.push(keys.len() as u32);
                            table.split_uses.push(0);
                            table.plan.push(None);
                        }
                        let i = e as usize;
                        table.split_uses[i] = table.split_uses[i].saturating_add(1);
                        i
                    })
                    .collect()
            })
            .collect();
        (table, face_ids)
    }
}

/// The canonical loops of the face table's entries, concatenated.
struct Loops {
    ids: Vec<u32>,
    start: Vec<u32>,
}

impl Loops {
    /// Entries with a loop so far.
    fn len(&self) -> usize {
        self.start.len() - 1
    }
    /// Entry `i`'s loop.
    fn get(&self, i: usize) -> &[u32] {
        &self.ids[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

/// What the face plans read of the input grid.
struct PlanContext<'a> {
    cells: &'a Cells,
    points: &'a [P3],
    split: &'a [bool],
    is_hidden: &'a (dyn Fn(usize) -> bool + Sync),
}

impl PlanContext<'_> {
    /// Plans every face of the split cells, in first-use order (new vertex
    /// ids are deterministic): whole when planar and convex, or when it is
    /// used by one split cell and shared with a live cell that is not
    /// split; else a fan from a new vertex, or ear clipping.
    fn plan_faces(
        &self,
        found: &[Found],
        face_ids: &[Vec<usize>],
        table: &mut FaceTable,
        new: &mut NewPoints,
        report: &mut SplitReport,
    ) {
        let pos = |v: u32| self.points[v as usize];
        // Loops per face entry (first occurrence, canonical): entries are
        // numbered in first-use order, so entry i's loop is the i-th new one.
        let mut loops = Loops {
            ids: Vec::new(),
            start: vec![0],
        };
        for ((_, faces), ids) in found.iter().zip(face_ids) {
            for (f, &i) in faces.iter().zip(ids) {
                if i == loops.len() {
                    let (i0, same) = canonical_start(f);
                    loops
                        .ids
                        .extend((0..f.len()).map(|k| canonical_at(f, i0, same, k)));
                    loops.start.push(loops.ids.len() as u32);
                }
            }
        }
        // Bad faces (non-planar or non-convex), each on its own.
        let bad: Vec<bool> = (0..loops.len())
            .into_par_iter()
            .map_init(Vec::new, |pts: &mut Vec<P3>, i| {
                pts.clear();
                pts.extend(loops.get(i).iter().map(|&v| pos(v)));
                face_is_bad(pts)
            })
            .collect();
        let shared = self.shared_with_unsplit(&loops, &bad, &table.split_uses);
        let np0 = self.points.len();
        for ((_, faces), ids) in found.iter().zip(face_ids) {
            for &i in ids.iter().take(faces.len()) {
                if table.plan[i].is_some() {
                    continue;
                }
                let l = loops.get(i);
                let plan = if !bad[i] {
                    FacePlan::Whole
                } else if table.split_uses[i] == 1 && shared[i] {
                    report.kept_faces += 1;
                    FacePlan::Whole
                } else {
                    report.triangulated_faces += 1;
                    let pts: Vec<P3> = l.iter().map(|&v| pos(v)).collect();
                    if let Some(q) = fan_point(&pts) {
                        let id = np0 + new.points.len();
                        new.push(q, l);
                        FacePlan::Fan(id as u32)
                    } else if let Some(t) = ear_clip(l, &pts) {
                        FacePlan::Ears(t)
                    } else {
                        // Self-intersecting or degenerate: every split cell
                        // with this face is skipped ([`cell_star`]).
                        FacePlan::Failed
                    }
                };
                table.plan[i] = Some(plan);
            }
        }
    }

    /// Per face entry: whether it is a bad face used by one split cell
    /// whose vertices a live cell that is not split all uses (the cell
    /// across it may share it). One pass over the cells: a bit per point
    /// (small enough to stay in cache) marks the first vertex of each such
    /// face and picks the few cells with a marked vertex; their ids are
    /// checked against the faces chained at that vertex while in cache
    /// (rather than listed per vertex and read again at random).
    fn shared_with_unsplit(&self, loops: &Loops, bad: &[bool], split_uses: &[u8]) -> Vec<bool> {
        const NONE: u32 = u32::MAX;
        let mut head = vec![NONE; self.points.len()];
        let mut next = vec![NONE; loops.len()];
        let mut bits = vec![0u64; self.points.len().div_ceil(64)];
        for i in 0..loops.len() {
            if bad[i] && split_uses[i] == 1 {
                let v = loops.get(i)[0] as usize;
                next[i] = head[v];
                head[v] = i as u32;
                bits[v / 64] |= 1 << (v % 64);
            }
        }
        let live = |c: usize| {
            !(self.split[c] || (self.is_hidden)(c) || is_lower_dimensional(self.cells.types[c]))
        };
        let is_marked = |v: u32| {
            bits.get(v as usize / 64)
                .is_some_and(|w| w >> (v % 64) & 1 == 1)
        };
        // Chunks of cells in parallel list the faces they find shared (a
        // set: the order of the chunks does not matter).
        const CELLS: usize = 1 << 14;
        let found: Vec<Vec<u32>> = (0..self.cells.len().div_ceil(CELLS))
            .into_par_iter()
            .map(|b| {
                let mut out = Vec::new();
                for c in b * CELLS..self.cells.len().min((b + 1) * CELLS) {
                    let ids = self.cells.cell(c);
                    if !(ids.iter().any(|&v| is_marked(v)) && live(c)) {
                        continue;
                    }
                    for &v in ids.iter().filter(|&&v| is_marked(v)) {
                        let mut f = head[v as usize];
                        while f != NONE {
                            let i = f as usize;
                            if loops.get(i).iter().all(|x| ids.contains(x)) {
                                out.push(f);
                            }
                            f = next[i];
                        }
                    }
                }
                out
            })
            .collect();
        let mut shared = vec![false; loops.len()];
        for i in found.into_iter().flatten() {
            shared[i as usize] = true;
        }
        shared
    }
}

/// The boundary elements of split cell `c` after its faces' plans, oriented
/// outward, with the face each comes from; an error naming `c` and its face
/// when a face could not be triangulated.
fn boundary_elements<'a>(
    c: usize,
    faces: &'a FaceLoops,
    ids: &[usize],
    table: &FaceTable,
) -> Result<Vec<(usize, Element<'a>)>, SplitError> {
    let mut elems: Vec<(usize, Element<'a>)> = Vec::new();
    for (fi, (f, &i)) in faces.iter().zip(ids).enumerate() {
        let (i0, same) = canonical_start(f);
        let orient = |t: [u32; 3]| if same { t } else { [t[0], t[2], t[1]] };
        match table.plan[i].as_ref().expect("planned") {
            FacePlan::Failed => return Err(SplitError::Face { cell: c, face: fi }),
            FacePlan::Whole => elems.push((fi, Element::Base(f))),
            FacePlan::Fan(q) => {
                let k = f.len();
                let can = |j: usize| canonical_at(f, i0, same, j % k);
                for j in 0..k {
                    elems.push((fi, Element::Tri(orient([*q, can(j), can(j + 1)]))));
                }
            }
            FacePlan::Ears(tris) => {
                for &t in tris {
                    elems.push((fi, Element::Tri(orient(t))));
                }
            }
        }
    }
    Ok(elems)
}

/// Volume centroid of the closed boundary `elems` (cones from `vm`).
fn volume_centroid(elems: &[(usize, Element)], vm: P3, cpos: &impl Fn(u32) -> P3) -> P3 {
    let mut vol = 0.0;
    let mut acc = [0.0; 3];
    for (_, e) in elems {
        let ids: &[u32] = match e {
            Element::Base(ids) => ids,
            Element::Tri(t) => t,
        };
        let p0 = cpos(ids[0]);
        for j in 1..ids.len() - 1 {
            let (pj, pk) = (cpos(ids[j]), cpos(ids[j + 1]));
            let w = dot(sub(p0, vm), cross(sub(pj, vm), sub(pk, vm))) / 6.0;
            vol += w;
            acc = add(acc, scale(add(add(add(p0, pj), pk), vm), w / 4.0));
        }
    }
    scale(acc, 1.0 / vol)
}

/// Split cell `c`'s boundary elements, vertices and star point: the first
/// of its volume centroid, vertex mean and kernel point that sees every
/// element, else a vertex that sees every face it is not on (its faces
/// through it then get no piece); an error when there is none.
fn cell_star<'a>(
    c: usize,
    faces: &'a FaceLoops,
    ids: &[usize],
    table: &FaceTable,
    points: &[P3],
    cpos: &(impl Fn(u32) -> P3 + Sync),
) -> Result<CellStar<'a>, SplitError> {
    let mut elems = boundary_elements(c, faces, ids, table)?;
    let mut verts: Vec<u32> = faces.ids.clone();
    verts.sort_unstable();
    verts.dedup();
    let vm = mean(verts.iter().map(|&v| points[v as usize]));
    let ext = verts
        .iter()
        .map(|&v| norm(sub(points[v as usize], vm)))
        .fold(0.0, f64::max);
    let tol = CONVEXITY_TOLERANCE * ext;
    let planes: Vec<(usize, Option<(P3, P3)>)> = elems
        .iter()
        .map(|(fi, e)| (*fi, element_plane(e, cpos)))
        .collect();
    let centroid = volume_centroid(&elems, vm, cpos);
    // The first element a point does not see, if any.
    let hidden_from = |p: P3| {
        planes.iter().find_map(|(fi, pl)| match pl {
            Some((o, nh)) if dot(sub(p, *o), *nh) < -tol => None,
            _ => Some(*fi),
        })
    };
    let mut best_face = hidden_from(centroid);
    let mut apex = best_face.is_none().then_some(centroid);
    if apex.is_none() && hidden_from(vm).is_none() {
        apex = Some(vm);
    }
    if apex.is_none() && planes.iter().all(|(_, p)| p.is_some()) {
        let pl: Vec<(P3, P3)> = planes.iter().map(|(_, p)| p.expect("plane")).collect();
        if let Some(k) = kernel_point(&pl, 2.0 * tol, 1e-9 * ext) {
            match hidden_from(k) {
                None => apex = Some(k),
                Some(f) => best_face = Some(f),
            }
        }
    }
    let star = match apex {
        Some(apex) => {
            debug_assert!(elems.iter().all(|(_, e)| cone_volume(e, apex, cpos) > 0.0));
            Star::Apex(apex)
        }
        // No interior point: pull from a vertex that sees every face
        // it is not on (thin slivers between warped faces).
        None => match verts.iter().copied().find(|&v| {
            planes.iter().all(|(fi, pl)| {
                faces.get(*fi).contains(&v)
                    || matches!(pl, Some((o, nh)) if dot(sub(points[v as usize], *o), *nh) < -tol)
            })
        }) {
            Some(v) => {
                elems.retain(|(fi, _)| !faces.get(*fi).contains(&v));
                Star::Vertex(v)
            }
            None => {
                return Err(SplitError::NotStarShaped {
                    cell: c,
                    face: best_face.unwrap_or(0),
                });
            }
        },
    };
    Ok((elems, verts, star))
}

/// In cell order: each split cell's apex id (a new vertex, or the pulled
/// vertex) and its pieces. A cell that cannot be split (a face that cannot
/// be triangulated, or no star point) gets no piece: it is skipped and
/// counted in the report, with the first such cell's reason.
fn cut_cells(
    found: &[Found],
    stars: Vec<Result<CellStar<'_>, SplitError>>,
    np0: usize,
    new: &mut NewPoints,
    report: &mut SplitReport,
) -> Pieces {
    let mut out = Pieces::default();
    for ((c, _), star) in found.iter().zip(stars) {
        let (elems, verts, star) = match star {
            Ok(s) => s,
            Err(e) => {
                report.skipped += 1;
                if report.skipped_first.len() < FIRST_IDS {
                    report.skipped_first.push(*c);
                }
                if report.skipped_reason.is_empty() {
                    report.skipped_reason = e.to_string();
                }
                out.end_cell(*c);
                continue;
            }
        };
        let p = match star {
            Star::Apex(apex) => {
                new.push(apex, &verts);
                (np0 + new.points.len() - 1) as u32
            }
            Star::Vertex(v) => {
                report.vertex_pulled += 1;
                v
            }
        };
        for (_, e) in &elems {
            match e {
                Element::Tri([a, b, c]) => out.push(vtk_type::TETRA, &[*a, *c, *b, p]),
                Element::Base(ids) if ids.len() == 3 => {
                    out.push(vtk_type::TETRA, &[ids[0], ids[2], ids[1], p])
                }
                Element::Base(ids) if ids.len() == 4 => {
                    out.push(vtk_type::PYRAMID, &[ids[0], ids[3], ids[2], ids[1], p])
                }
                Element::Base(ids) => {
                    // A polyhedron: the base loop, then the apex.
                    out.ids.extend_from_slice(ids);
                    out.push(vtk_type::POLYHEDRON, &[p]);
                }
            }
        }
        report.pieces += elems.len();
        out.end_cell(*c);
    }
    out
}

/// Copies the input cells `a..b` (a run of unsplit cells) in bulk.
fn copy_run(cells: &Cells, out: &mut Cells, source: &mut Vec<u32>, a: usize, b: usize) {
    if a == b {
        return;
    }
    out.types.extend_from_slice(&cells.types[a..b]);
    let (ca, cb) = (cells.offsets[a], cells.offsets[b]);
    let shift = out.connectivity.len() as u32;
    out.connectivity
        .extend_from_slice(&cells.connectivity[ca as usize..cb as usize]);
    out.offsets
        .extend(cells.offsets[a + 1..=b].iter().map(|&o| o - ca + shift));
    let fs = out.face_stream.len() as u32;
    if cells.face_offsets.is_empty() {
        out.face_offsets.extend(std::iter::repeat_n(fs, b - a));
    } else {
        let (fa, fb) = (cells.face_offsets[a], cells.face_offsets[b]);
        out.face_stream
            .extend_from_slice(&cells.face_stream[fa as usize..fb as usize]);
        out.face_offsets
            .extend(cells.face_offsets[a + 1..=b].iter().map(|&o| o - fa + fs));
    }
    source.extend(a as u32..b as u32);
}

/// The output cells: runs of unsplit cells copied in bulk, the pieces in
/// place of their cell; and the source cell of each output cell.
fn assemble(cells: &Cells, pieces_of: &Pieces) -> Result<(Cells, Vec<u32>), SplitError> {
    let n = cells.len();
    let piece_stream = |ids: &[u32]| 2 + 4 * (ids.len() - 1) + ids.len() - 1;
    let (mut out_cells, mut out_conn, mut out_stream) = (n, cells.connectivity.len(), 0usize);
    let stream_of = |c: usize| cells.faces_of(c).len();
    out_stream += cells.face_stream.len();
    for i in 0..pieces_of.cells.len() {
        let (c, pieces) = pieces_of.of(i);
        out_cells -= 1;
        out_conn -= cells.cell(c).len();
        out_stream -= stream_of(c);
        for (t, ids) in pieces {
            out_cells += 1;
            out_conn += ids.len();
            if t == vtk_type::POLYHEDRON {
                out_stream += piece_stream(ids);
            }
        }
    }
    if out_cells >= u32::MAX as usize {
        return Err(SplitError::TooLarge(format!("{out_cells} cells")));
    }
    let mut out = Cells {
        types: Vec::with_capacity(out_cells),
        offsets: Vec::with_capacity(out_cells + 1),
        connectivity: Vec::with_capacity(out_conn),
        face_offsets: Vec::with_capacity(out_cells + 1),
        face_stream: Vec::with_capacity(out_stream),
    };
    out.offsets.push(0);
    out.face_offsets.push(0);
    let mut source = Vec::with_capacity(out_cells);
    let mut done = 0;
    for i in 0..pieces_of.cells.len() {
        let (c, pieces) = pieces_of.of(i);
        copy_run(cells, &mut out, &mut source, done, c);
        for (t, ids) in pieces {
            push_piece(&mut out, t, ids);
            source.push(c as u32);
        }
        done = c + 1;
    }
    copy_run(cells, &mut out, &mut source, done, n);
    debug_assert_eq!(
        (
            out.types.len(),
            out.connectivity.len(),
            out.face_stream.len()
        ),
        (out_cells, out_conn, out_stream)
    );
    Ok((out, source))
}

/// Appends a piece (a polyhedron piece is its base loop, then its apex).
fn push_piece(out: &mut Cells, t: u8, ids: &[u32]) {
    if t == vtk_type::POLYHEDRON {
        let (apex, base) = ids.split_last().expect("base and apex");
        let k = base.len();
        let mut faces = vec![base.to_vec()];
        for j in 0..k {
            faces.push(vec![base[(j + 1) % k], base[j], *apex]);
        }
        out.push_polyhedron(&faces);
    } else {
        out.push(t, ids);
    }
}

/// The input's point data extended to the new vertices (means) and its
/// cell data gathered per output cell.
fn carry_properties(grid: &Grid, map: &SplitMap) -> (Vec<Property>, Vec<Property>) {
    let point_data = grid
        .point_data
        .iter()
        .map(|p| extend_point_property(p, map))
        .collect();
    let cell_data = grid
        .cell_data
        .iter()
        .map(|p| {
            let values = gather_tuples(&map.source, &p.values, p.components.max(1));
            Property {
                name: p.name.clone(),
                components: p.components,
                values,
            }
        })
        .collect();
    (point_data, cell_data)
}
