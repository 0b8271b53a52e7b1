//! Construction of a [`Ciel`] from face lists (the paper's §4.2), linear in
//! the input and free of per-cell allocations.
//!
//! 1. Exact per-cell bounds (half-edges, faces) give each chunk of cells its
//!    part of the final arrays. Per chunk (in parallel, scratch buffers
//!    reused): face loops are read straight from the face stream (or the
//!    catalog's faces for typed cells), checked, oriented and written as
//!    half-edges with their `mate_face` offsets; each face leaves a record
//!    keyed by its smallest vertex and that vertex's two loop neighbours.
//! 2. Parts left short by cells found dead slide down in order
//!    (deterministic; nothing moves when every cell is live).
//! 3. `mate_cell`: face records are grouped by smallest vertex (a parallel
//!    stable counting sort), each group is sorted by its keys and equal keys
//!    are matched by their reversed loops (in parallel over vertex ranges).
//! 4. Vertex cycles: a half-edge is the representative of its fan (the
//!    half-edges with the same origin around one edge, linked by
//!    `mate_face`∘`mate_cell`) when it has the smallest id of the fan; the
//!    representatives are grouped per origin vertex (CSR, the same counting
//!    sort), in id order.

use rayon::prelude::*;

use super::link::{FaceRec, Linked, START, vertex_cycles};
use super::{
    Ciel, CielCounts, CielError, FIRST_IN_FACE, LAST_IN_FACE, LOOKUP_SHIFT, MAX_CELL_HALF_EDGES,
    NONE, VERTEX_MASK, structured_as_cells,
};
use crate::grid::{Cells, Grid, Topology, is_lower_dimensional, vtk_type};
use crate::mem::split_lengths;
use crate::mem::try_filled;
use crate::metacell::{Catalog, VOXEL_TO_HEX, builtin};
use crate::structures::common::{CellClass, classify_cell, is_sweepable};
use crate::structures::polyhedron::{Scratch, check_cell, parse_faces_into};

/// Cells per parallel task of the per-cell phase.
const CHUNK_CELLS: usize = 1024;

/// What one chunk of cells produced besides the half-edges, faces and
/// cell starts it wrote into its parts of the final arrays.
#[derive(Default)]
struct ChunkOut {
    /// Half-edges and faces written.
    half_edges: usize,
    faces: usize,
    class_counts: [usize; crate::structures::CELL_CLASS_COUNT],
    hidden: usize,
    flipped: usize,
    /// Live cells found non-convex.
    non_convex: Vec<u32>,
}

/// One chunk's parts of the final arrays, sized by [`cell_bounds`].
struct ChunkParts<'a> {
    /// Global id of the first half-edge of `origins`.
    base: u32,
    origins: &'a mut [u32],
    mate_face: &'a mut [i16],
    faces: &'a mut [FaceRec],
    /// The chunk's cells' first half-edges (global ids).
    cell_start: &'a mut [u32],
}

/// The catalog meta-cell of a typed volumetric cell.
fn typed_meta(t: u8, prisms: &[(u8, u16)]) -> Option<u16> {
    Some(match t {
        vtk_type::TETRA => builtin::TETRA,
        vtk_type::PYRAMID => builtin::PYRAMID,
        vtk_type::WEDGE => builtin::WEDGE,
        vtk_type::HEXAHEDRON | vtk_type::VOXEL => builtin::HEXAHEDRON,
        _ => prisms.iter().find(|p| p.0 == t)?.1,
    })
}

/// (half-edges, faces) that cell `c` writes if it is live and valid: exact
/// for every cell whose faces parse, so that chunks can write straight into
/// the final arrays (cells found dead leave a gap, closed afterwards).
fn cell_bounds(
    cells: &Cells,
    c: usize,
    catalog: &Catalog,
    prisms: &[(u8, u16)],
    hidden: Option<&[bool]>,
) -> (usize, usize) {
    let t = cells.types[c];
    if is_lower_dimensional(t) || hidden.is_some_and(|h| h.get(c).copied().unwrap_or(false)) {
        return (0, 0);
    }
    if t == vtk_type::POLYHEDRON {
        let stream = cells.faces_of(c);
        let nf = (stream.first().copied().unwrap_or(0) as usize).min(stream.len());
        return (stream.len().saturating_sub(1 + nf), nf);
    }
    match typed_meta(t, prisms) {
        Some(meta) => {
            let m = catalog.get(meta);
            (m.faces.iter().map(|f| f.len()).sum(), m.faces.len())
        }
        None => (0, 0),
    }
}

/// Writes the face loops (global ids) of cell `c` into `s.ids`/`s.starts`;
/// returns the cell's class when it is not volumetric (nothing written).
fn cell_faces(
    cells: &Cells,
    c: usize,
    catalog: &Catalog,
    prisms: &[(u8, u16)],
    points: &[[f64; 3]],
    s: &mut Scratch,
) -> Result<Option<CellClass>, CielError> {
    let t = cells.types[c];
    if is_lower_dimensional(t) {
        return Ok(Some(CellClass::NonVolumetric));
    }
    if t == vtk_type::POLYHEDRON {
        parse_faces_into(c, cells.faces_of(c), &mut s.ids, &mut s.starts)?;
        return Ok(None);
    }
    let ids = cells.cell(c);
    let Some(meta) = typed_meta(t, prisms) else {
        return Err(CielError::FaceStream {
            cell: c,
            why: format!("unsupported VTK cell type {t}"),
        });
    };
    let m = catalog.get(meta);
    let local = &mut s.tmp;
    local.clear();
    if t == vtk_type::VOXEL {
        if ids.len() != 8 {
            return Err(CielError::FaceStream {
                cell: c,
                why: "voxel without 8 vertices".into(),
            });
        }
        local.extend(VOXEL_TO_HEX.iter().map(|&i| ids[i]));
    } else {
        local.extend_from_slice(ids);
    }
    if local.len() != m.nv {
        return Err(CielError::FaceStream {
            cell: c,
            why: format!(
                "{} vertices for a cell of type {t} ({} expected)",
                local.len(),
                m.nv
            ),
        });
    }
    // Typed cells: classified exactly as the CGraph does.
    let class = classify_cell(m, local, points);
    if !is_sweepable(class) {
        return Ok(Some(class));
    }
    s.ids.clear();
    s.starts.clear();
    s.starts.push(0);
    for f in &m.faces {
        s.ids.extend(f.iter().map(|&l| local[l as usize]));
        s.starts.push(s.ids.len() as u32);
    }
    Ok(None)
}

/// The per-cell phase over cells `range`, written into `parts`.
fn build_chunk(
    range: std::ops::Range<usize>,
    cells: &Cells,
    catalog: &Catalog,
    prisms: &[(u8, u16)],
    points: &[[f64; 3]],
    hidden: Option<&[bool]>,
    parts: ChunkParts,
) -> Result<ChunkOut, CielError> {
    let mut s = Scratch::default();
    let mut out = ChunkOut::default();
    let first = range.start;
    for c in range {
        parts.cell_start[c - first] = parts.base + out.half_edges as u32;
        let class = match cell_faces(cells, c, catalog, prisms, points, &mut s)? {
            Some(class) => class,
            None => {
                let (class, flipped, non_convex) = check_cell(c, points, &mut s)?;
                let hide = hidden.is_some_and(|h| h.get(c).copied().unwrap_or(false));
                if is_sweepable(class) && hide {
                    // Checked like any cell, then left out of the structure.
                    out.hidden += 1;
                } else if is_sweepable(class) {
                    let n = s.ids.len();
                    if n > MAX_CELL_HALF_EDGES {
                        return Err(CielError::TooLarge(format!(
                            "cell {c} has {n} half-edges (at most {MAX_CELL_HALF_EDGES} per cell)"
                        )));
                    }
                    let nf = s.starts.len() - 1;
                    let he = out.half_edges;
                    let (Some(origins), Some(mate_face), Some(faces)) = (
                        parts.origins.get_mut(he..he + n),
                        parts.mate_face.get_mut(he..he + n),
                        parts.faces.get_mut(out.faces..out.faces + nf),
                    ) else {
                        return Err(CielError::FaceStream {
                            cell: c,
                            why: "more half-edges than its face stream announces".into(),
                        });
                    };
                    out.flipped += flipped;
                    if non_convex {
                        out.non_convex.push(c as u32);
                    }
                    let base = parts.base + he as u32;
                    // (`s.fkeys` holds each face's key, in face order.)
                    let keys = s.starts.windows(2).zip(&s.fkeys);
                    for ((w, &(m, lo, hi, _)), rec) in keys.zip(faces.iter_mut()) {
                        let (a, b) = (w[0] as usize, w[1] as usize);
                        let face = &s.ids[a..b];
                        *rec = [base + a as u32, m, lo, hi];
                        origins[a..b].copy_from_slice(face);
                        origins[a] |= FIRST_IN_FACE;
                        origins[b - 1] |= LAST_IN_FACE;
                    }
                    for (i, (d, &m)) in mate_face.iter_mut().zip(&s.mate).enumerate() {
                        *d = (m as i64 - i as i64) as i16;
                    }
                    out.half_edges += n;
                    out.faces += nf;
                    out.class_counts[class as usize] += 1;
                    continue;
                }
                class
            }
        };
        out.class_counts[class as usize] += 1;
    }
    Ok(out)
}

/// The cells of the `k`-th chunk of `n` cells.
fn chunk_range(k: usize, n: usize) -> std::ops::Range<usize> {
    k * CHUNK_CELLS..((k + 1) * CHUNK_CELLS).min(n)
}

/// The per-cell phase's output: the final arrays and the counts.
struct CellPhase {
    origins: Vec<u32>,
    mate_face: Vec<i16>,
    cell_start: Vec<u32>,
    faces: Vec<FaceRec>,
    counts: CielCounts,
    non_convex_cells: Vec<u32>,
}

impl CellPhase {
    /// Per chunk of cells, in parallel, straight into the final arrays at
    /// offsets from the exact per-cell bounds (the first error in cell order
    /// wins); then the gaps closed ([`CellPhase::close_gaps`]).
    fn run(
        cells: &Cells,
        catalog: &Catalog,
        prisms: &[(u8, u16)],
        points: &[[f64; 3]],
        hidden: Option<&[bool]>,
    ) -> Result<Self, CielError> {
        let n = cells.len();
        let nchunks = n.div_ceil(CHUNK_CELLS);
        let bounds: Vec<(usize, usize)> = (0..nchunks)
            .into_par_iter()
            .map(|k| {
                chunk_range(k, n).fold((0, 0), |(h, f), c| {
                    let (ch, cf) = cell_bounds(cells, c, catalog, prisms, hidden);
                    (h + ch, f + cf)
                })
            })
            .collect();
        let he_bound: usize = bounds.iter().map(|b| b.0).sum();
        let face_bound: usize = bounds.iter().map(|b| b.1).sum();
        if he_bound >= (1usize << 31) - 1 {
            return Err(CielError::TooLarge(format!("{he_bound} half-edges")));
        }
        let mut phase = CellPhase {
            origins: try_filled(he_bound, 0u32, "CIEL's half-edge origins")?,
            mate_face: try_filled(he_bound, 0i16, "CIEL's half-edge mates")?,
            cell_start: try_filled(n + 1, 0u32, "CIEL's cell starts")?,
            faces: try_filled(face_bound, [0; 4], "CIEL's faces")?,
            counts: CielCounts::default(),
            non_convex_cells: Vec::new(),
        };
        let he_lens: Vec<usize> = bounds.iter().map(|b| b.0).collect();
        let face_lens: Vec<usize> = bounds.iter().map(|b| b.1).collect();
        let cell_lens: Vec<usize> = (0..nchunks).map(|k| chunk_range(k, n).len()).collect();
        let mut he_bases = Vec::with_capacity(nchunks);
        let mut acc = 0usize;
        for &l in &he_lens {
            he_bases.push(acc);
            acc += l;
        }
        let parts: Vec<ChunkParts> = split_lengths(&mut phase.origins, &he_lens)
            .into_iter()
            .zip(split_lengths(&mut phase.mate_face, &he_lens))
            .zip(split_lengths(&mut phase.faces, &face_lens))
            .zip(split_lengths(&mut phase.cell_start[..n], &cell_lens))
            .zip(&he_bases)
            .map(|((((o, m), f), c), &base)| ChunkParts {
                base: base as u32,
                origins: o,
                mate_face: m,
                faces: f,
                cell_start: c,
            })
            .collect();
        let chunks: Vec<Result<ChunkOut, CielError>> = parts
            .into_par_iter()
            .enumerate()
            .map(|(k, p)| build_chunk(chunk_range(k, n), cells, catalog, prisms, points, hidden, p))
            .collect();
        let chunks: Vec<ChunkOut> = chunks.into_iter().collect::<Result<_, _>>()?;
        phase.close_gaps(&chunks, &he_bases, &face_lens)?;
        phase.tally(&chunks);
        Ok(phase)
    }

    /// Closes the gaps left by cells found dead (rare): chunks slide down
    /// in order, their face and cell starts shifted with them.
    fn close_gaps(
        &mut self,
        chunks: &[ChunkOut],
        he_bases: &[usize],
        face_lens: &[usize],
    ) -> Result<(), CielError> {
        let n = self.cell_start.len() - 1;
        let mut total = 0usize;
        let mut nfaces = 0usize;
        let mut face_base = 0usize;
        for (k, ch) in chunks.iter().enumerate() {
            let (hb, fb) = (he_bases[k], face_base);
            face_base += face_lens[k];
            if hb != total || fb != nfaces {
                let shift = (hb - total) as u32;
                self.origins.copy_within(hb..hb + ch.half_edges, total);
                self.mate_face.copy_within(hb..hb + ch.half_edges, total);
                self.faces.copy_within(fb..fb + ch.faces, nfaces);
                for f in &mut self.faces[nfaces..nfaces + ch.faces] {
                    f[START] -= shift;
                }
                for s in &mut self.cell_start[chunk_range(k, n)] {
                    *s -= shift;
                }
            }
            total += ch.half_edges;
            nfaces += ch.faces;
        }
        self.origins.truncate(total);
        self.mate_face.truncate(total);
        self.faces.truncate(nfaces);
        if total == 0 {
            return Err(CielError::NoCells);
        }
        self.cell_start[n] = total as u32;
        Ok(())
    }

    /// Sums the chunks' counts and gathers their non-convex cells.
    fn tally(&mut self, chunks: &[ChunkOut]) {
        let counts = &mut self.counts;
        for ch in chunks {
            for k in 0..5 {
                counts.class_counts[k] += ch.class_counts[k];
            }
            counts.hidden += ch.hidden;
            counts.flipped_faces += ch.flipped;
            counts.non_convex += ch.non_convex.len();
            self.non_convex_cells.extend_from_slice(&ch.non_convex);
        }
        counts.faces = self.faces.len();
    }
}

/// Per block of `1 << LOOKUP_SHIFT` half-edges, the cell of its first.
fn cell_lookup(cell_start: &[u32], total: usize) -> Vec<u32> {
    let mut cell_lookup = Vec::with_capacity((total >> LOOKUP_SHIFT) + 1);
    let mut c = 0usize;
    for b in 0..=((total - 1) >> LOOKUP_SHIFT) {
        let h = (b << LOOKUP_SHIFT) as u32;
        while cell_start[c + 1] <= h {
            c += 1;
        }
        cell_lookup.push(c as u32);
    }
    cell_lookup
}

impl Ciel {
    /// Builds the CIEL of a grid (structured grids become hexahedra).
    /// `hidden` marks cells to exclude.
    pub fn build(grid: &Grid, hidden: Option<&[bool]>) -> Result<Self, CielError> {
        let points = &grid.points;
        let np = points.len();
        if np >= VERTEX_MASK as usize {
            return Err(CielError::TooLarge(format!("{np} vertices")));
        }
        let mut catalog = Catalog::new();
        let structured_cells;
        let cells = match &grid.topology {
            Topology::Unstructured(c) => c,
            Topology::Structured { dims } => {
                structured_cells = structured_as_cells(*dims);
                &structured_cells
            }
        };
        // Prism meta-cells only when the grid has prisms.
        let prisms: Vec<(u8, u16)> = [vtk_type::PENTAGONAL_PRISM, vtk_type::HEXAGONAL_PRISM]
            .iter()
            .filter(|&&t| cells.types.contains(&t))
            .filter_map(|&t| catalog.for_vtk_type(t).map(|m| (t, m)))
            .collect();
        let CellPhase {
            origins,
            mate_face,
            cell_start,
            faces,
            mut counts,
            non_convex_cells,
        } = CellPhase::run(cells, &catalog, &prisms, points, hidden)?;
        let total = origins.len();
        // 3. mate_cell: faces bucketed by smallest vertex (counting sort).
        let mate_cell = Linked {
            faces: &faces,
            origins: &origins,
            cell_start: &cell_start,
            total,
        }
        .mate_cells(np)?;
        drop(faces);
        counts.border_half_edges = mate_cell.par_iter().filter(|&&m| m == NONE).count();
        // 4. Vertex cycles: representatives (smallest id of each fan), CSR by origin.
        let (vertex_start, vertex_edges) = vertex_cycles(np, &origins, &mate_face, &mate_cell);
        counts.edges = vertex_edges.len() / 2;
        let cell_lookup = cell_lookup(&cell_start, total);
        Ok(Ciel {
            origin: grid.origin(),
            positions: grid.rebased_positions()?,
            origins,
            mate_faces: mate_face,
            mate_cells: mate_cell,
            cell_start,
            cell_lookup,
            vertex_start,
            vertex_edges,
            non_convex_cells,
            counts,
        })
    }
}
