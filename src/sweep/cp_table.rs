//! Fixed-size per-code rows for the corner-point graph's emitter: for each
//! meta-cell of at most [`ROW_EDGES`] edges (tetrahedra, pyramids, wedges,
//! hexahedra) and each code without an ambiguous face, the cut edges as
//! local vertex pairs and the polygons as indices into them, so emitting a
//! cut cell reads one row instead of the catalog's variant, loop and edge
//! tables. Same polygons, corners and order as
//! [`crate::extract::emit_cell`] (the rows are read off
//! [`MetaCell::loops`]).

use crate::metacell::{Catalog, MetaCell};

/// Most edges of a tabled meta-cell (a hexahedron's): every cut edge is
/// one corner of one polygon, so also the most corners of a row.
pub(super) const ROW_EDGES: usize = 12;
/// Most polygons of a row.
const ROW_POLYS: usize = 6;

/// One code of one meta-cell (see the module docs).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct CodeRow {
    /// Local vertex pairs (`a < b`) of the cut edges, in first-use order.
    pub(super) ends: [[u8; 2]; ROW_EDGES],
    /// The polygons' corners, polygon after polygon: indices into `ends`.
    pub(super) corners: [u8; ROW_EDGES],
    /// Corners per polygon.
    pub(super) sizes: [u8; ROW_POLYS],
    /// Cut edges (entries of `ends`).
    pub(super) edges: u8,
    /// Polygons; 0 when the code is emitted the generic way (an ambiguous
    /// face, or no polygon). A row with polygons has at least three edges.
    pub(super) polys: u8,
}

/// The rows of every tabled meta-cell of a catalog, in one array.
#[derive(Clone, Debug, Default)]
pub(super) struct CodeTable {
    /// Per meta-cell id: where its `2^nv` rows start, or `u32::MAX`.
    first: Vec<u32>,
    /// The rows.
    rows: Vec<CodeRow>,
}

impl CodeTable {
    /// Rows for the meta-cells of `catalog` with at most [`ROW_EDGES`]
    /// edges and 8 vertices; `used(id)` says which are worth tabling.
    pub(super) fn new(catalog: &Catalog, used: impl Fn(usize) -> bool) -> Self {
        let mut t = CodeTable::default();
        for (id, m) in catalog.metas.iter().enumerate() {
            if used(id) && m.nv <= 8 && m.edges.len() <= ROW_EDGES {
                t.first.push(t.rows.len() as u32);
                t.rows
                    .extend((0..1usize << m.nv).map(|code| row_of(m, code)));
            } else {
                t.first.push(u32::MAX);
            }
        }
        t
    }

    /// The row of `code` (below `2^nv`) for meta-cell `meta`, when it is
    /// tabled.
    #[inline(always)]
    pub(super) fn row(&self, meta: u16, code: usize) -> Option<&CodeRow> {
        let first = *self.first.get(meta as usize)?;
        let row = self.rows.get((first as usize).wrapping_add(code))?;
        (first != u32::MAX && row.polys != 0).then_some(row)
    }
}

/// The row of `code` of `m` (`polys` 0 when it has an ambiguous face or
/// more polygons than a row holds).
fn row_of(m: &MetaCell, code: usize) -> CodeRow {
    let mut row = CodeRow::default();
    if m.ambiguous_faces[code] != 0 {
        return row;
    }
    let mut local = [u8::MAX; 64];
    let mut corners = 0usize;
    let mut polys = 0usize;
    for lp in m.loops(code, 0) {
        if polys == ROW_POLYS {
            return CodeRow::default();
        }
        for &e in lp {
            let e = e as usize;
            if local[e] == u8::MAX {
                if row.edges as usize == ROW_EDGES {
                    return CodeRow::default();
                }
                local[e] = row.edges;
                row.ends[row.edges as usize] = m.edges[e];
                row.edges += 1;
            }
            if corners == ROW_EDGES {
                return CodeRow::default();
            }
            row.corners[corners] = local[e];
            corners += 1;
        }
        row.sizes[polys] = lp.len() as u8;
        polys += 1;
    }
    if row.edges < 3 {
        // Never for a polygon; the emitter relies on three edges.
        return CodeRow::default();
    }
    row.polys = polys as u8;
    row
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metacell::builtin;

    /// Every tabled row gives the catalog's loops, edge for edge.
    #[test]
    fn rows_follow_the_catalog_loops() {
        let catalog = Catalog::new();
        let table = CodeTable::new(&catalog, |_| true);
        let mut tabled = 0;
        for (id, m) in catalog.metas.iter().enumerate() {
            for code in 0..1usize << m.nv {
                let Some(row) = table.row(id as u16, code) else {
                    let plain = m.ambiguous_faces[code] == 0 && m.loops(code, 0).count() > 0;
                    assert!(
                        !plain || m.edges.len() > ROW_EDGES,
                        "{} code {code}",
                        m.name
                    );
                    continue;
                };
                tabled += 1;
                let mut first = 0;
                let loops: Vec<&[u8]> = m.loops(code, 0).collect();
                assert_eq!(loops.len(), row.polys as usize);
                for (p, lp) in loops.iter().enumerate() {
                    assert_eq!(lp.len(), row.sizes[p] as usize);
                    for (i, &e) in lp.iter().enumerate() {
                        let c = row.corners[first + i] as usize;
                        assert!(c < row.edges as usize);
                        assert_eq!(row.ends[c], m.edges[e as usize]);
                    }
                    first += lp.len();
                }
            }
        }
        // Most codes of the four built-in cells have no ambiguous face.
        assert!(tabled > 200, "{tabled}");
        assert!(table.row(builtin::HEXAHEDRON, 0).is_none());
    }
}
