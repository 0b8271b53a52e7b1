//! [`CornerPointGrid::into_grid`]'s passes: classify the cells (pass 1),
//! count the output per IJ row (pass 2), weld the corners per pillar
//! (pass 3), merge coincident corners across pillars, write the cells
//! deepest layer first while ZCORN shrinks behind (pass 4), then the points,
//! the renumbering of merged vertices and the restricted properties.

use rayon::prelude::*;

use super::shapes::{
    CODE_ACTIVE, CODE_CROSS, CODE_NEG, CODE_ZERO, CrossCell, Shape, VTK_ORDER_LEFT,
    VTK_ORDER_RIGHT, cross_pattern, find, kept, pillar_pattern, search_from, shape_of,
};
use super::{CornerPointError, CornerPointGrid, CornerPointReport, trilinear_volume};
use crate::grid::{Cells, Grid, Property, Topology, vtk_type};
use crate::mem::split_lengths;
use crate::mem::{AllocError, try_filled};

/// Pass 1's result for one IJ row: the signed volume of its active cells,
/// the |volume| of its kept cells without cross-pillar merges, and the
/// cells whose corners coincide across pillars.
type RowSums = (f64, f64, Vec<CrossCell>);

/// Per column of a row: the depths (bits) and ids of the top corners of
/// the last kept cell of that column in a deeper layer.
type Below = ([u64; 4], [u32; 4]);

/// [`split_lengths`] by start offsets: the pieces `start[i]..start[i + 1]`.
fn split_at_starts<'a, T>(v: &'a mut [T], start: &[usize]) -> Vec<&'a mut [T]> {
    let lens: Vec<usize> = start.windows(2).map(|w| w[1] - w[0]).collect();
    split_lengths(v, &lens)
}

/// The shapes of the kept cells: by collapsed pillar pattern, or by
/// cross-pillar merge pattern for the cells whose merge gave a valid shape.
struct Shapes {
    /// Shape by pattern of collapsed pillar edges (code bits 0–3).
    pillar: Vec<Shape>,
    /// The distinct valid cross-pillar merge patterns and their shapes.
    cross_shapes: Vec<([u8; 8], Shape)>,
    /// (cell, index into `cross_shapes`), ascending by cell.
    cross_cells: Vec<(usize, usize)>,
}

impl Shapes {
    /// Pillar-only patterns always give a closed surface (or a flat one).
    /// Cross-pillar merges that give a valid shape keep it; the others (a
    /// face through a corner twice, an open surface) keep their pillar-only
    /// shape and their unmerged vertices (counted). Adds the cross cells'
    /// volumes to the report's bulk volume.
    fn resolve(rows: Vec<RowSums>, order: &[usize; 8], rep: &mut CornerPointReport) -> Self {
        let pillar: Vec<Shape> = (0..16u8)
            .map(|m| shape_of(&pillar_pattern(m), order).unwrap_or(Shape::Flat))
            .collect();
        let mut cross_shapes: Vec<([u8; 8], Shape)> = Vec::new();
        let mut cross_cells: Vec<(usize, usize)> = Vec::new();
        for cc in rows.into_iter().flat_map(|r| r.2) {
            rep.bulk_volume += cc.volume;
            let s = match cross_shapes.iter().position(|(r, _)| *r == cc.rep) {
                Some(s) => s,
                None => match shape_of(&cc.rep, order) {
                    Some(Shape::Flat) | None => {
                        rep.merge_fallback += 1;
                        continue;
                    }
                    Some(shape) => {
                        cross_shapes.push((cc.rep, shape));
                        cross_shapes.len() - 1
                    }
                },
            };
            cross_cells.push((cc.cell, s));
        }
        Shapes {
            pillar,
            cross_shapes,
            cross_cells,
        }
    }

    /// The shape of a kept cell and whether it uses merged vertices.
    #[inline]
    fn at(&self, c: usize, code: u8) -> (&Shape, bool) {
        if code & CODE_CROSS != 0
            && let Ok(x) = self.cross_cells.binary_search_by_key(&c, |e| e.0)
        {
            return (&self.cross_shapes[self.cross_cells[x].1].1, true);
        }
        (&self.pillar[(code & 15) as usize], false)
    }
}

/// Pass 2's output sizes: per IJ row (row `j + ny·k`) its first cell,
/// connectivity entry and face stream entry (one past the end last).
struct Layout {
    cell_start: Vec<usize>,
    conn_start: Vec<usize>,
    face_start: Vec<usize>,
    /// Totals: cells, connectivity, face stream, hexahedra, wedges,
    /// pyramids, tetrahedra, polyhedra, inverted, active, collapsed.
    totals: [usize; 11],
}

impl Layout {
    /// Pass 2 (parallel over rows): class counts and output sizes per row.
    fn count(codes: &[u8], nx: usize, left: bool, shapes: &Shapes) -> Self {
        let counts: Vec<[usize; 11]> = codes
            .par_chunks(nx)
            .enumerate()
            .map(|(row, cs)| Self::count_row(cs, nx * row, left, shapes))
            .collect();
        let nrows = counts.len();
        let mut cell_start = Vec::with_capacity(nrows + 1);
        let mut conn_start = Vec::with_capacity(nrows + 1);
        let mut face_start = Vec::with_capacity(nrows + 1);
        let mut acc = [0usize; 11];
        for r in &counts {
            cell_start.push(acc[0]);
            conn_start.push(acc[1]);
            face_start.push(acc[2]);
            for (a, b) in acc.iter_mut().zip(r) {
                *a += b;
            }
        }
        cell_start.push(acc[0]);
        conn_start.push(acc[1]);
        face_start.push(acc[2]);
        Layout {
            cell_start,
            conn_start,
            face_start,
            totals: acc,
        }
    }

    /// The counts of one row whose first cell is `first` (see `totals`).
    fn count_row(cs: &[u8], first: usize, left: bool, shapes: &Shapes) -> [usize; 11] {
        let mut r = [0usize; 11];
        for (i, &code) in cs.iter().enumerate() {
            if code & CODE_ACTIVE == 0 {
                continue;
            }
            r[9] += 1;
            if code & 15 != 0 {
                r[10] += 1;
            }
            if !kept(code) {
                continue;
            }
            r[0] += 1;
            if (code & CODE_NEG != 0) != left {
                r[8] += 1;
            }
            match shapes.at(i + first, code).0 {
                Shape::Typed(t, ids) => {
                    r[1] += ids.len();
                    r[match *t {
                        vtk_type::HEXAHEDRON => 3,
                        vtk_type::WEDGE => 4,
                        vtk_type::PYRAMID => 5,
                        _ => 6,
                    }] += 1;
                }
                Shape::Poly(f) => {
                    let mut v: Vec<u8> = f.iter().flatten().copied().collect();
                    v.sort_unstable();
                    v.dedup();
                    r[1] += v.len();
                    r[2] += 1 + f.iter().map(|l| 1 + l.len()).sum::<usize>();
                    r[7] += 1;
                }
                Shape::Flat => {}
            }
        }
        r
    }

    /// Number of kept cells.
    fn kept_cells(&self) -> usize {
        self.totals[0]
    }

    /// Writes the class counts into the report (`n` cells in the grid).
    fn report(&self, rep: &mut CornerPointReport, n: usize) {
        let acc = &self.totals;
        rep.active = acc[9];
        rep.inactive = n - acc[9];
        rep.collapsed = acc[10];
        rep.zero_volume = acc[9] - acc[0];
        rep.inverted = acc[8];
        (
            rep.hexahedra,
            rep.wedges,
            rep.pyramids,
            rep.tetrahedra,
            rep.polyhedra,
        ) = (acc[3], acc[4], acc[5], acc[6], acc[7]);
    }
}

/// Pass 3's welded vertices: per pillar the sorted unique depths of the
/// kept cells' corners; vertex ids run pillar by pillar.
struct PillarDepths {
    /// Pillars per row (`nx + 1`).
    npx: usize,
    /// Layers of cells.
    nz: usize,
    /// First vertex id of each pillar, and the vertex count at the end.
    start: Vec<usize>,
    /// Per row of pillars: its pillars' depths one after the other, and
    /// their counts.
    rows: Vec<(Vec<f64>, Vec<u32>)>,
}

impl PillarDepths {
    /// Pass 3: weld corners per pillar (sorted unique depths of kept
    /// cells), in parallel over rows of pillars so that ZCORN is read row
    /// by row; per pillar row one vector of its pillars' depths.
    fn build(g: &CornerPointGrid, codes: &[u8], zcorn: &[f64]) -> Result<Self, CornerPointError> {
        let [nx, ny, nz] = g.dims;
        let npx = nx + 1;
        let npil = npx * (ny + 1);
        let rows: Vec<(Vec<f64>, Vec<u32>)> = (0..=ny)
            .into_par_iter()
            .map_init(Vec::new, |scratch, pj| {
                Self::row(g, codes, zcorn, pj, scratch)
            })
            .collect();
        let mut start = Vec::with_capacity(npil + 1);
        let mut nv = 0usize;
        for (_, lens) in &rows {
            for &l in lens {
                start.push(nv);
                nv += l as usize;
            }
        }
        start.push(nv);
        if nv >= u32::MAX as usize {
            return Err(CornerPointError::BadDims(g.dims));
        }
        Ok(PillarDepths {
            npx,
            nz,
            start,
            rows,
        })
    }

    /// The depths of the pillars of row `pj`, one after the other, and
    /// their counts. One scratch block of 8·nz depths per pillar (4 cells ×
    /// top and bottom per layer), sorted and deduplicated in place. The
    /// scratch is reused from row to row: only the depths written for this
    /// row are read, so it is zeroed once, not per row (101 rows of 646 KB
    /// on a 100³ grid).
    fn row(
        g: &CornerPointGrid,
        codes: &[u8],
        zcorn: &[f64],
        pj: usize,
        scratch: &mut Vec<f64>,
    ) -> (Vec<f64>, Vec<u32>) {
        let [nx, ny, nz] = g.dims;
        let npx = nx + 1;
        let per = 8 * nz;
        scratch.resize(per * npx, 0.0);
        let mut len = vec![0usize; npx];
        for k in 0..nz {
            for kk in 0..2 {
                for (cj, jj) in [(pj.wrapping_sub(1), 1usize), (pj, 0)] {
                    if cj >= ny {
                        continue;
                    }
                    let row = &codes[nx * (cj + ny * k)..][..nx];
                    let z0 = g.zcorn_index(0, cj, k, 2 * jj + 4 * kk);
                    let zrow = &zcorn[z0..z0 + 2 * nx];
                    for (i, &code) in row.iter().enumerate() {
                        if kept(code) {
                            scratch[per * i + len[i]] = zrow[2 * i];
                            len[i] += 1;
                            scratch[per * (i + 1) + len[i + 1]] = zrow[2 * i + 1];
                            len[i + 1] += 1;
                        }
                    }
                }
            }
        }
        let mut flat = Vec::new();
        let mut lens = Vec::with_capacity(npx);
        for (p, &l) in len.iter().enumerate() {
            let d = &mut scratch[per * p..per * p + l];
            // Runs in layer order: the stable sort merges them.
            d.sort_by(|a, b| a.total_cmp(b));
            let before = flat.len();
            for &z in d.iter() {
                if flat.len() == before || flat.last() != Some(&z) {
                    flat.push(z);
                }
            }
            lens.push((flat.len() - before) as u32);
        }
        flat.shrink_to_fit();
        (flat, lens)
    }

    /// Number of welded vertices.
    fn vertices(&self) -> usize {
        self.start[self.start.len() - 1]
    }

    /// The depths of pillar `p` (ids `start[p]..start[p + 1]`).
    #[inline]
    fn depths(&self, p: usize) -> &[f64] {
        let base = self.start[p - p % self.npx];
        &self.rows[p / self.npx].0[self.start[p] - base..self.start[p + 1] - base]
    }

    /// [`Self::vid`] of a top corner (`corner` < 4) searched from just
    /// above `below`, the vertex of the bottom corner on the same pillar
    /// (the same id: the search's result does not depend on where it
    /// starts).
    #[inline]
    fn vid_near(
        &self,
        g: &CornerPointGrid,
        zcorn: &[f64],
        [i, j, k]: [usize; 3],
        corner: usize,
        below: u32,
    ) -> u32 {
        let (pi, pj) = (i + (corner & 1), j + (corner >> 1 & 1));
        let p = pi + self.npx * pj;
        let base = self.start[self.npx * pj];
        let d = &self.rows[pj].0[self.start[p] - base..self.start[p + 1] - base];
        let z = zcorn[g.zcorn_index(i, j, k, corner)];
        let guess = (below as usize).saturating_sub(self.start[p] + 1);
        (self.start[p] + search_from(d, z, guess)) as u32
    }

    /// The welded vertex id of corner `corner` of cell (i, j, k).
    #[inline]
    fn vid(&self, g: &CornerPointGrid, zcorn: &[f64], [i, j, k]: [usize; 3], corner: usize) -> u32 {
        let (pi, pj) = (i + (corner & 1), j + (corner >> 1 & 1));
        let p = pi + self.npx * pj;
        let base = self.start[self.npx * pj];
        let d = &self.rows[pj].0[self.start[p] - base..self.start[p + 1] - base];
        let z = zcorn[g.zcorn_index(i, j, k, corner)];
        // Layer k's corners sit near index k·len/(nz+1) of a pillar.
        let guess = (k + (corner >> 2)) * d.len() / (self.nz + 1);
        (self.start[p] + search_from(d, z, guess)) as u32
    }
}

/// The output arrays of the kept cells.
struct CellArrays {
    types: Vec<u8>,
    offsets: Vec<u32>,
    connectivity: Vec<u32>,
    /// Input cell of each output cell (ascending).
    source: Vec<u32>,
    face_offsets: Vec<u32>,
    face_stream: Vec<u32>,
}

impl CellArrays {
    /// Zeroed arrays of the sizes counted in pass 2, or the one that does
    /// not fit in memory.
    fn new(layout: &Layout) -> Result<Self, AllocError> {
        let kept_cells = layout.kept_cells();
        let (nconn, nfaces) = (layout.totals[1], layout.totals[2]);
        Ok(CellArrays {
            types: try_filled(kept_cells, 0u8, "the cell types")?,
            offsets: try_filled(kept_cells + 1, 0u32, "the cell offsets")?,
            connectivity: try_filled(nconn, 0u32, "the cell connectivity")?,
            source: try_filled(kept_cells, 0u32, "the cells' source cells")?,
            face_offsets: if nfaces > 0 {
                try_filled(kept_cells + 1, 0u32, "the polyhedra's face offsets")?
            } else {
                Vec::new()
            },
            face_stream: try_filled(nfaces, 0u32, "the polyhedra's faces")?,
        })
    }
}

/// One IJ row's share of the output arrays (offsets without the leading 0).
struct RowOut<'a> {
    types: &'a mut [u8],
    offsets: &'a mut [u32],
    source: &'a mut [u32],
    face_offsets: &'a mut [u32],
    conn: &'a mut [u32],
    faces: &'a mut [u32],
}

/// Pass 4: writes the kept cells of each layer into [`CellArrays`].
struct CellWriter<'a> {
    grid: &'a CornerPointGrid,
    codes: &'a [u8],
    shapes: &'a Shapes,
    depths: &'a PillarDepths,
    /// Canonical vertex of each welded vertex after cross-pillar merges.
    canon: Option<&'a [u32]>,
    layout: &'a Layout,
    /// Bottom corners reuse the ids of the top corners of the cell below.
    reuse_below: bool,
}

impl CellWriter<'_> {
    /// Cells, deepest layer first, each layer's rows in parallel; ZCORN
    /// shrinks behind.
    fn write_layers(&self, zcorn: &mut Vec<f64>, out: &mut CellArrays) {
        let [nx, ny, nz] = self.grid.dims;
        let (cell_start, conn_start, face_start) = (
            &self.layout.cell_start,
            &self.layout.conn_start,
            &self.layout.face_start,
        );
        // Per row, per i: see [`Below`]. A vertex id depends only on the
        // pillar and the depth, so a bottom corner at the same depth on the
        // same pillar reuses it (no search); the NaN bits of the start
        // never match a depth.
        let mut below: Vec<Vec<Below>> = vec![vec![([u64::MAX; 4], [0; 4]); nx]; ny];
        for k in (0..nz).rev() {
            let rs = k * ny..(k + 1) * ny + 1;
            let (c0, c1) = (cell_start[k * ny], cell_start[(k + 1) * ny]);
            let starts = &cell_start[rs.clone()];
            let t = split_at_starts(&mut out.types[c0..c1], starts);
            let o = split_at_starts(&mut out.offsets[c0 + 1..c1 + 1], starts);
            let s = split_at_starts(&mut out.source[c0..c1], starts);
            let fo = if out.face_offsets.is_empty() {
                (0..ny).map(|_| &mut [][..]).collect()
            } else {
                split_at_starts(&mut out.face_offsets[c0 + 1..c1 + 1], starts)
            };
            let cn = split_at_starts(
                &mut out.connectivity[conn_start[k * ny]..conn_start[(k + 1) * ny]],
                &conn_start[rs.clone()],
            );
            let fs = split_at_starts(
                &mut out.face_stream[face_start[k * ny]..face_start[(k + 1) * ny]],
                &face_start[rs.clone()],
            );
            let jobs: Vec<_> = t
                .into_iter()
                .zip(o)
                .zip(s)
                .zip(fo)
                .zip(cn.into_iter().zip(fs))
                .zip(below.iter_mut())
                .enumerate()
                .collect();
            let zc = &zcorn[..];
            jobs.into_par_iter()
                .for_each(|(j, (((((t, o), s), fo), (cn, fs)), below))| {
                    let row = RowOut {
                        types: t,
                        offsets: o,
                        source: s,
                        face_offsets: fo,
                        conn: cn,
                        faces: fs,
                    };
                    self.write_row(zc, j, k, row, below);
                });
            zcorn.truncate(8 * nx * ny * k);
            if zcorn.capacity() - zcorn.len() >= 1 << 17 {
                zcorn.shrink_to_fit();
            }
        }
    }

    /// Writes the kept cells of IJ row (j, k).
    fn write_row(&self, zc: &[f64], j: usize, k: usize, out: RowOut, below: &mut [Below]) {
        let (g, nx) = (self.grid, self.grid.dims[0]);
        let row = j + g.dims[1] * k;
        let (conn_base, face_base) = (self.layout.conn_start[row], self.layout.face_start[row]);
        let (mut x, mut ce, mut fe) = (0usize, 0usize, 0usize);
        let mut ids: Vec<u32> = Vec::with_capacity(8);
        // The previous kept cell of the row: its corner depths and vertex
        // ids (a corner on the shared pillar at the same depth is the same
        // vertex).
        let mut prev: Option<(usize, [f64; 8], [u32; 8])> = None;
        for i in 0..nx {
            let c = i + nx * row;
            let code = self.codes[c];
            if !kept(code) {
                continue;
            }
            let (shape, merged) = self.shapes.at(c, code);
            // Plain loops rather than `array::from_fn`: whether from_fn's
            // closures were inlined here depended on how the crate falls
            // into codegen units (+0.5 G instructions on f100 when not).
            let mut z = [0.0f64; 8];
            for (q, zq) in z.iter_mut().enumerate() {
                *zq = zc[g.zcorn_index(i, j, k, q)];
            }
            let (bz, bw) = &mut below[i];
            // Bottom corners first: a top corner is then searched from
            // just above the bottom corner on its pillar (usually the next
            // depth up, in the same cache line).
            // A corner on the pillar shared with the previous cell of the
            // row, at the same depth, is that cell's vertex.
            let from_prev = |q: usize| match prev {
                Some((pi, pz, pw)) if pi + 1 == i && q & 1 == 0 && pz[q + 1] == z[q] => {
                    Some(pw[q + 1])
                }
                _ => None,
            };
            let mut raw = [0u32; 8];
            for b in 0..4 {
                let q = b + 4;
                raw[q] = match from_prev(q) {
                    Some(v) => v,
                    None if self.reuse_below && bz[b] == z[q].to_bits() => bw[b],
                    None => self.depths.vid(g, zc, [i, j, k], q),
                };
            }
            for q in 0..4 {
                raw[q] = from_prev(q)
                    .unwrap_or_else(|| self.depths.vid_near(g, zc, [i, j, k], q, raw[q + 4]));
            }
            prev = Some((i, z, raw));
            for q in 0..4 {
                bz[q] = z[q].to_bits();
                bw[q] = raw[q];
            }
            let mut w = raw;
            if let (Some(cm), true) = (self.canon, merged || code & CODE_CROSS == 0) {
                w = w.map(|v| cm[v as usize]);
            }
            match shape {
                Shape::Typed(ty, local) => {
                    out.types[x] = *ty;
                    for &l in local {
                        out.conn[ce] = w[l as usize];
                        ce += 1;
                    }
                }
                Shape::Poly(f) => {
                    out.types[x] = vtk_type::POLYHEDRON;
                    ids.clear();
                    ids.extend(f.iter().flatten().map(|&l| w[l as usize]));
                    ids.sort_unstable();
                    ids.dedup();
                    out.conn[ce..ce + ids.len()].copy_from_slice(&ids);
                    ce += ids.len();
                    out.faces[fe] = f.len() as u32;
                    fe += 1;
                    for l in f {
                        out.faces[fe] = l.len() as u32;
                        fe += 1;
                        for &q in l {
                            out.faces[fe] = w[q as usize];
                            fe += 1;
                        }
                    }
                }
                Shape::Flat => unreachable!("flat cells are not kept"),
            }
            out.offsets[x] = (conn_base + ce) as u32;
            if !out.face_offsets.is_empty() {
                out.face_offsets[x] = (face_base + fe) as u32;
            }
            out.source[x] = c as u32;
            x += 1;
        }
    }
}

/// Drops the vertices merged away: renumbers the used ones, keeping their
/// order, in the connectivity and the face stream.
fn renumber(points: &mut Vec<[f64; 3]>, connectivity: &mut [u32], face_stream: &mut [u32]) {
    let mut new_id = vec![u32::MAX; points.len()];
    for &v in connectivity.iter() {
        new_id[v as usize] = 0;
    }
    let mut next = 0u32;
    for (v, id) in new_id.iter_mut().enumerate() {
        if *id == 0 {
            *id = next;
            points[next as usize] = points[v];
            next += 1;
        }
    }
    points.truncate(next as usize);
    points.shrink_to_fit();
    for v in connectivity.iter_mut() {
        *v = new_id[*v as usize];
    }
    let mut f = 0;
    while f < face_stream.len() {
        let nf = face_stream[f] as usize;
        f += 1;
        for _ in 0..nf {
            let len = face_stream[f] as usize;
            for v in &mut face_stream[f + 1..f + 1 + len] {
                *v = new_id[*v as usize];
            }
            f += 1 + len;
        }
    }
}

/// Restricts the cell properties to the kept cells, in place (`source`
/// ascends).
fn restrict(cell_data: &mut [Property], source: &[u32]) {
    for p in cell_data {
        let k = p.components.max(1);
        p.components = k;
        for (o, &s) in source.iter().enumerate() {
            let s = s as usize;
            p.values.copy_within(s * k..(s + 1) * k, o * k);
        }
        p.values.truncate(source.len() * k);
        p.values.shrink_to_fit();
    }
}

impl CornerPointGrid {
    /// [`CornerPointGrid::into_grid`]; `reuse_below` lets a cell's bottom
    /// corners take the ids found for the top corners of the cell below
    /// instead of searching the pillar (same ids: tested against `false`).
    pub(super) fn into_grid_with(
        mut self,
        reuse_below: bool,
    ) -> Result<(Grid, CornerPointReport), CornerPointError> {
        self.validate()?;
        let [nx, ny, nz] = self.dims;
        let n = nx * ny * nz;
        let tr = self.transform();
        let mut zcorn = std::mem::take(&mut self.zcorn);
        let (codes, rows) = self.classify(&zcorn, &tr)?;
        let total: f64 = rows.iter().map(|r| r.0).sum();
        let left = total <= 0.0;
        let order = if left {
            &VTK_ORDER_LEFT
        } else {
            &VTK_ORDER_RIGHT
        };
        let mut rep = CornerPointReport {
            cells: n,
            ijk_right_handed_up: !left,
            bulk_volume: rows.iter().map(|r| r.1).sum(),
            ..Default::default()
        };
        let shapes = Shapes::resolve(rows, order, &mut rep);
        let layout = Layout::count(&codes, nx, left, &shapes);
        if layout.totals[1] >= u32::MAX as usize || layout.totals[2] >= u32::MAX as usize {
            return Err(CornerPointError::BadDims(self.dims));
        }
        layout.report(&mut rep, n);
        let depths = PillarDepths::build(&self, &codes, &zcorn)?;
        let canon = self.merge_map(&shapes, &depths, &zcorn);
        let mut cells = CellArrays::new(&layout)?;
        CellWriter {
            grid: &self,
            codes: &codes,
            shapes: &shapes,
            depths: &depths,
            canon: canon.as_deref(),
            layout: &layout,
            reuse_below,
        }
        .write_layers(&mut zcorn, &mut cells);
        drop(zcorn);
        drop(codes);
        // Points, after ZCORN is gone.
        let mut points = self.points(&tr, &depths)?;
        drop(depths);
        if canon.is_some() {
            renumber(&mut points, &mut cells.connectivity, &mut cells.face_stream);
        }
        rep.vertices = points.len();
        let mut cell_data = std::mem::take(&mut self.properties);
        restrict(&mut cell_data, &cells.source);
        rep.source_cell = cells.source;
        let cells = Cells {
            types: cells.types,
            offsets: cells.offsets,
            connectivity: cells.connectivity,
            face_offsets: cells.face_offsets,
            face_stream: cells.face_stream,
        };
        Ok((
            Grid {
                points,
                topology: Topology::Unstructured(cells),
                point_data: Vec::new(),
                cell_data,
            },
            rep,
        ))
    }

    /// Pass 1 (parallel over IJ rows): per cell a code (collapsed pillar
    /// edges and flags), per row its [`RowSums`].
    fn classify(
        &self,
        zcorn: &[f64],
        tr: &[f64; 6],
    ) -> Result<(Vec<u8>, Vec<RowSums>), AllocError> {
        let [nx, ny, nz] = self.dims;
        let flat_pillar: [bool; 16] = std::array::from_fn(|m| {
            matches!(
                shape_of(&pillar_pattern(m as u8), &VTK_ORDER_LEFT),
                Some(Shape::Flat)
            )
        });
        let identity = Self::is_identity(tr);
        let mut codes = try_filled(nx * ny * nz, 0u8, "the cell codes")?;
        let rows: Vec<RowSums> = codes
            .par_chunks_mut(nx)
            .enumerate()
            .map(|(row, out)| {
                let (j, k) = (row % ny, row / ny);
                let (mut signed, mut kept_abs, mut cross) = (0.0, 0.0, Vec::new());
                // The previous active cell of the row: its corners' depth
                // bits and positions (a corner on the shared pillar with
                // the same depth bits has the same position).
                let mut prev: Option<(usize, [u64; 8], [[f64; 3]; 8])> = None;
                for (i, code) in out.iter_mut().enumerate() {
                    let c = i + nx * row;
                    if !self.is_active(c) {
                        continue;
                    }
                    // Plain loops, not `array::from_fn` (see `write_row`).
                    let mut z = [0.0f64; 8];
                    let mut zb = [0u64; 8];
                    for q in 0..8 {
                        z[q] = zcorn[self.zcorn_index(i, j, k, q)];
                        zb[q] = z[q].to_bits();
                    }
                    let mut corners = [[0.0f64; 3]; 8];
                    for q in 0..8 {
                        corners[q] = match prev {
                            Some((pi, pz, pc))
                                if pi + 1 == i && q & 1 == 0 && pz[q + 1] == zb[q] =>
                            {
                                pc[q + 1]
                            }
                            _ => {
                                let p = self.pillar_index(i + (q & 1), j + (q >> 1 & 1));
                                Self::apply_with(identity, tr, self.on_pillar(p, z[q]))
                            }
                        };
                    }
                    prev = Some((i, zb, corners));
                    let mut ext = 0.0f64;
                    for q in &corners[1..] {
                        for a in 0..3 {
                            ext = ext.max((q[a] - corners[0][a]).abs());
                        }
                    }
                    let mut m = 0u8;
                    for p in 0..4 {
                        if z[p] == z[p + 4] {
                            m |= 1 << p;
                        }
                    }
                    let vol = trilinear_volume(&corners);
                    let mut cd = CODE_ACTIVE | m;
                    if vol < 0.0 {
                        cd |= CODE_NEG;
                    }
                    signed += vol;
                    if flat_pillar[m as usize] || vol.abs() <= 1e-12 * ext * ext * ext {
                        cd |= CODE_ZERO;
                    } else if let Some(rep) = cross_pattern(&corners, &z, 1e-9 * ext) {
                        cd |= CODE_CROSS;
                        cross.push(CrossCell {
                            cell: c,
                            rep,
                            volume: vol.abs(),
                        });
                    } else {
                        kept_abs += vol.abs();
                    }
                    *code = cd;
                }
                (signed, kept_abs, cross)
            })
            .collect();
        Ok((codes, rows))
    }

    /// Cross-pillar merges: unions the coincident vertices (smallest id
    /// wins) and gives each welded vertex its canonical one; `None` when no
    /// cell merges across pillars.
    fn merge_map(&self, shapes: &Shapes, depths: &PillarDepths, zcorn: &[f64]) -> Option<Vec<u32>> {
        let [nx, ny, _] = self.dims;
        let nv = depths.vertices();
        (!shapes.cross_cells.is_empty()).then(|| {
            let mut parent: Vec<u32> = (0..nv as u32).collect();
            for &(c, s) in &shapes.cross_cells {
                let ijk = [c % nx, c / nx % ny, c / (nx * ny)];
                let r = &shapes.cross_shapes[s].0;
                for q in 0..8 {
                    let (a, b) = (
                        depths.vid(self, zcorn, ijk, q),
                        depths.vid(self, zcorn, ijk, r[q] as usize),
                    );
                    let (a, b) = (find(&mut parent, a), find(&mut parent, b));
                    parent[a.max(b) as usize] = a.min(b);
                }
            }
            for v in 0..nv as u32 {
                parent[v as usize] = find(&mut parent, v);
            }
            parent
        })
    }

    /// World positions of the welded vertices, in parallel over pillars.
    fn points(&self, tr: &[f64; 6], depths: &PillarDepths) -> Result<Vec<[f64; 3]>, AllocError> {
        let mut points = try_filled(depths.vertices(), [0.0f64; 3], "the points")?;
        split_at_starts(&mut points, &depths.start)
            .into_par_iter()
            .enumerate()
            .for_each(|(p, out)| {
                for (o, &z) in out.iter_mut().zip(depths.depths(p)) {
                    *o = Self::apply(tr, self.on_pillar(p, z));
                }
            });
        Ok(points)
    }
}
