//! Host-side images of the GPU buffers: the meta-cell catalog flattened into
//! one `u32` table, the grid (positions + φ, attribute, zoo cells) and one
//! frame's per-level active cell lists. The GPU passes and the CPU twin
//! read exactly these vectors.

use crate::cancel::{Cancel, Interrupted, catch_interrupt, stop_if_cancelled};
use crate::extract::EmitContext;
use crate::field::ScalarField;
use crate::metacell::{Catalog, MAX_META_VERTICES, builtin};
use crate::structures::scgraph::SCGraph;
use crate::sweep::{CellGraph, LevelStats, Sweeper};

use crate::gpu::shared::{
    ATTR_CELL, ATTR_NONE, ATTR_VERTEX, EmitParams, Entry, META_WORDS, MetaInfo, TableSections,
    WORKGROUP,
};

/// Flattens a catalog into one `u32` buffer with its section starts.
///
/// Global variant and loop indices are rebased so that one meta-cell's
/// tables follow the previous one's; each meta-cell's faces get a sentinel.
pub fn flatten_catalog(c: &Catalog) -> (Vec<u32>, TableSections) {
    let mut metas = Vec::new();
    let mut codes = Vec::new();
    let mut variants = Vec::new();
    let mut loops = Vec::new();
    let mut config = Vec::new();
    let mut edges = Vec::new();
    let mut face_start = Vec::new();
    let mut face_verts = Vec::new();
    for m in &c.metas {
        let info = MetaInfo {
            nv: m.nv as u32,
            edge_base: edges.len() as u32,
            face_base: face_start.len() as u32,
            face_count: m.faces.len() as u32,
            code_base: codes.len() as u32,
            ..Default::default()
        };
        metas.extend_from_slice(bytemuck::cast_slice::<MetaInfo, u32>(&[info]));
        let variant0 = variants.len() as u32;
        let loop0 = loops.len() as u32 / 2;
        let config0 = config.len() as u32;
        for code in 0..m.code_count() {
            codes.push(m.ambiguous_faces[code]);
            codes.push(variant0 + m.variant_base[code]);
        }
        let nvar = m.variant_loops.len() - 1;
        for v in 0..nvar {
            variants.push(loop0 + m.variant_loops[v]);
        }
        for l in 0..m.config_size.len() {
            loops.push(config0 + m.loop_start[l]);
            loops.push(m.config_size[l] as u32);
        }
        config.extend(m.config.iter().map(|&e| e as u32));
        edges.extend(m.edges.iter().map(|&[a, b]| a as u32 | (b as u32) << 16));
        for f in &m.faces {
            face_start.push(face_verts.len() as u32);
            face_verts.extend(f.iter().map(|&v| v as u32));
        }
        face_start.push(face_verts.len() as u32);
    }
    variants.push(loops.len() as u32 / 2);
    let mut out = Vec::new();
    let mut sec = TableSections::default();
    for (dst, part) in [
        (&mut sec.metas, &metas),
        (&mut sec.codes, &codes),
        (&mut sec.variants, &variants),
        (&mut sec.loops, &loops),
        (&mut sec.config, &config),
        (&mut sec.edges, &edges),
        (&mut sec.face_start, &face_start),
        (&mut sec.face_verts, &face_verts),
    ] {
        *dst = out.len() as u32;
        out.extend_from_slice(part);
    }
    debug_assert_eq!(META_WORDS as usize * c.metas.len(), metas.len());
    (out, sec)
}

/// The grid side of the GPU buffers (uploaded once per field).
#[derive(Clone, Debug, Default)]
pub struct GridBuffers {
    /// S-CGraph (implicit hexahedra) rather than CGraph.
    pub structured: bool,
    /// S-CGraph: `npi · npj`.
    pub slab: u32,
    /// S-CGraph: meta id of its cells.
    pub hex_meta: u32,
    /// S-CGraph: vertex id offsets of the 8 local vertices.
    pub hex_offsets: [u32; 8],
    /// The flattened catalog.
    pub tables: Vec<u32>,
    /// Its sections.
    pub sections: TableSections,
    /// Per vertex: rebased position and φ.
    pub grid: Vec<[f32; 4]>,
    /// Per vertex attribute, or per slot when [`Self::attr_per_cell`]
    /// (empty: write the level value).
    pub attr: Vec<f32>,
    /// Without `attr`: the level's world value less its local one, as
    /// f32 (see [`crate::pipeline::level_value`]).
    pub level_offset: f32,
    /// `attr` holds one value per slot (a cell property shown flat per
    /// polygon) rather than one per vertex.
    pub attr_per_cell: bool,
    /// Per vertex: the field's gradient (xyz, w = 0) for iso lighting
    /// (empty: no normals are emitted). See [`super::gradient`].
    pub grad: Vec<[f32; 4]>,
    /// CGraph: per slot (meta id, first vertex word), then vertex ids.
    pub cells: Vec<u32>,
    /// The live slots (read by the span-space passes only).
    pub live: Vec<u32>,
}

impl GridBuffers {
    fn common<G: CellGraph, F: ScalarField>(g: &G, f: &F, attr: Option<&[f32]>) -> Self {
        let (tables, sections) = flatten_catalog(g.catalog());
        let grid = g
            .positions()
            .iter()
            .enumerate()
            .map(|(v, p)| [p[0], p[1], p[2], f.phi(v as u32)])
            .collect();
        let live = (0..g.slot_count() as u32)
            .filter(|&s| g.is_live(s))
            .collect();
        GridBuffers {
            tables,
            sections,
            grid,
            live,
            attr: attr.map(<[f32]>::to_vec).unwrap_or_default(),
            ..Default::default()
        }
    }

    /// Buffers of an S-CGraph: only dims-derived constants, no per-cell data.
    pub fn scgraph<F: ScalarField>(g: &SCGraph, f: &F, attr: Option<&[f32]>) -> Self {
        let slab = (g.dims[0] * g.dims[1]) as u32;
        let mut ids = [0u32; MAX_META_VERTICES];
        // The cell whose first vertex is vertex 0 gives the offsets.
        let (m, _) = g.cell(slab, &mut ids);
        let mut hex_offsets = [0u32; 8];
        hex_offsets.copy_from_slice(&ids[..8]);
        GridBuffers {
            structured: true,
            slab,
            hex_meta: m as u32,
            hex_offsets,
            ..Self::common(g, f, attr)
        }
    }

    /// Buffers of a CGraph: per live slot its meta id and vertex ids.
    pub fn cgraph<G: CellGraph, F: ScalarField>(g: &G, f: &F, attr: Option<&[f32]>) -> Self {
        let n = g.slot_count();
        let mut cells = vec![0u32; 2 * n];
        let mut ids = [0u32; MAX_META_VERTICES];
        for s in 0..n as u32 {
            if !g.is_live(s) {
                continue;
            }
            let (m, nv) = g.cell(s, &mut ids);
            cells[2 * s as usize] = m as u32;
            cells[2 * s as usize + 1] = cells.len() as u32;
            cells.extend_from_slice(&ids[..nv]);
        }
        GridBuffers {
            structured: false,
            hex_meta: builtin::HEXAHEDRON as u32,
            cells,
            ..Self::common(g, f, attr)
        }
    }

    /// Bytes of the grid-side buffers.
    pub fn bytes(&self) -> usize {
        (self.tables.len() + self.attr.len() + self.cells.len() + self.live.len()) * 4
            + (self.grid.len() + self.grad.len()) * 16
    }

    /// Meta id of the cell in a live `slot`, its vertex ids written to
    /// `ids`, and its vertex count (the load of `wgsl/shared/cell.wgsl`).
    pub fn cell_vertices(&self, slot: u32, ids: &mut [u32; MAX_META_VERTICES]) -> (u32, usize) {
        if self.structured {
            let v0 = slot - self.slab;
            for (id, o) in ids.iter_mut().zip(self.hex_offsets) {
                *id = v0 + o;
            }
            (self.hex_meta, 8)
        } else {
            let m = self.cells[2 * slot as usize];
            let start = self.cells[2 * slot as usize + 1] as usize;
            let b = (self.sections.metas + m * META_WORDS) as usize;
            let nv = self.tables[b] as usize;
            ids[..nv].copy_from_slice(&self.cells[start..start + nv]);
            (m, nv)
        }
    }
}

/// One frame's work: level values (local frame) and the (slot, level)
/// entries of the intersected cells, grouped by level.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    /// Level values, local frame, increasing.
    pub levels: Vec<f32>,
    /// Intersected cells, level by level.
    pub entries: Vec<Entry>,
    /// Per level: cells popped by the sweep (for statistics).
    pub visited: Vec<u64>,
}

impl Frame {
    /// The levels `a..b` as a frame of their own (levels renumbered from 0).
    pub fn level_range(&self, a: usize, b: usize) -> Frame {
        let lo = self.entries.partition_point(|e| (e.level as usize) < a);
        let hi = self.entries.partition_point(|e| (e.level as usize) < b);
        Frame {
            levels: self.levels[a..b].to_vec(),
            entries: self.entries[lo..hi]
                .iter()
                .map(|e| Entry {
                    slot: e.slot,
                    level: e.level - a as u32,
                })
                .collect(),
            visited: self
                .visited
                .get(a..b)
                .map(<[u64]>::to_vec)
                .unwrap_or_default(),
        }
    }
}

/// Runs the CPU sweep (`threads` spatial blocks) and collects per level the
/// intersected cells, in block order. The sweep runs with
/// [`EmitContext::cells_only`]: it records the cut cells and emits nothing
/// (the per-level stats returned alongside count cells and visits only).
/// Stops between levels once `cancel` is cancelled (`Interrupted`).
pub fn sweep_frame<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    axis_slot: Option<usize>,
    levels: &[f32],
    threads: usize,
    cancel: &Cancel,
) -> Result<(Frame, Vec<LevelStats>), Interrupted> {
    let mut sw = Sweeper::new(g, threads.max(1));
    sw.prepare_minima(f, axis_slot);
    let k = levels.len();
    let ctx = EmitContext {
        positions: g.positions(),
        attribute: None,
        cells_only: true,
    };
    let blocks = catch_interrupt(|| {
        sw.sweep(
            f,
            axis_slot,
            levels,
            &ctx,
            || (vec![Vec::<u32>::new(); k], vec![LevelStats::default(); k]),
            |acc, lv, mesh, st| {
                // Cells-only mode: one entry per cut cell.
                acc.0[lv].extend_from_slice(&mesh.cells);
                acc.1[lv] = *st;
                stop_if_cancelled(cancel);
            },
        )
    })?;
    let mut frame = Frame {
        levels: levels.to_vec(),
        entries: Vec::new(),
        visited: vec![0; k],
    };
    let mut stats = vec![LevelStats::default(); k];
    for lv in 0..k {
        for (lists, st) in &blocks {
            frame.entries.extend(lists[lv].iter().map(|&slot| Entry {
                slot,
                level: lv as u32,
            }));
            stats[lv].add(&st[lv]);
        }
        frame.visited[lv] = stats[lv].visited;
    }
    Ok((frame, stats))
}

/// Work groups (x, y) for `n` entries, with x at most `max_x`.
pub fn dispatch_size(n: u32, max_x: u32) -> (u32, u32) {
    let groups = n.div_ceil(WORKGROUP).max(1);
    let x = groups.min(max_x.max(1));
    (x, groups.div_ceil(x))
}

/// The [`EmitParams`] of a frame over `g`, with room for `capacity`
/// triangles, for a dispatch `row_groups` work groups wide.
pub fn emit_params(
    g: &GridBuffers,
    frame: &Frame,
    capacity: u32,
    write_areas: bool,
    row_groups: u32,
) -> EmitParams {
    let o = g.hex_offsets;
    EmitParams {
        entry_count: frame.entries.len() as u32,
        level_count: frame.levels.len() as u32,
        structured: g.structured as u32,
        has_attribute: match (g.attr.is_empty(), g.attr_per_cell) {
            (true, _) => ATTR_NONE,
            (false, false) => ATTR_VERTEX,
            (false, true) => ATTR_CELL,
        },
        has_gradient: !g.grad.is_empty() as u32,
        slab: g.slab,
        hex_meta: g.hex_meta,
        write_areas: write_areas as u32,
        row_width: row_groups * WORKGROUP,
        hex_offsets_lo: [o[0], o[1], o[2], o[3]],
        hex_offsets_hi: [o[4], o[5], o[6], o[7]],
        tables: g.sections,
        triangle_capacity: capacity,
        level_offset: g.level_offset,
        ..Default::default()
    }
}

/// One value per slot of `g`: the value of the slot's source cell in
/// `cell_values` (indexed by the input grid's cell id), 0 for dead slots
/// and cells without a value. Uploaded as the `attr` buffer with
/// [`GridBuffers::attr_per_cell`], it colours each polygon flat with its
/// own cell's value.
pub fn slot_values<G: CellGraph>(g: &G, cell_values: &[f64]) -> Vec<f32> {
    (0..g.slot_count() as u32)
        .map(|s| {
            if g.is_live(s) {
                cell_values
                    .get(g.source_cell(s) as usize)
                    .map_or(0.0, |&v| v as f32)
            } else {
                0.0
            }
        })
        .collect()
}
