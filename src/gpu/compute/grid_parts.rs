//! Grids over the device's buffer limits: the grid-side buffers split into
//! parts, each a contiguous range of slots with only the vertices its cells
//! reference, small enough for one storage binding. No wgpu here: the
//! emitter ([`super::emit`]) uploads one set of bindings per part and runs
//! the count and emit passes once per part into the same outputs.
//!
//! Every part keeps the order of the global vertex ids (an S-CGraph part is
//! a window of the vertex array, a CGraph part its referenced vertices
//! sorted), so the crossings are interpolated from the same end, the face
//! decider breaks ties on the same vertex, and a part emits bit for bit
//! the triangles the whole grid would.

use crate::metacell::MAX_META_VERTICES;

use super::tables::{Frame, GridBuffers};
use crate::gpu::shared::{Entry, META_WORDS};

/// One part: its own buffers (local slots `0..slot_hi - slot_lo`, local
/// vertex ids) and the global slot range it covers.
#[derive(Clone, Debug)]
pub struct GridPart {
    /// The part's buffers.
    pub buffers: GridBuffers,
    /// First global slot.
    pub slot_lo: u32,
    /// One past the last global slot.
    pub slot_hi: u32,
}

/// A single cell (its vertices or its table words) exceeds the budget.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CellTooLarge {
    /// The slot.
    pub slot: u32,
    /// Bytes the cell alone needs.
    pub bytes: u64,
    /// The per-buffer budget.
    pub budget: u64,
}

/// The largest single buffer among the grid-side buffers of `g` (the
/// catalog tables excluded: every part carries them whole).
pub fn largest_buffer(g: &GridBuffers) -> u64 {
    [
        g.grid.len() as u64 * 16,
        g.grad.len() as u64 * 16,
        g.attr.len() as u64 * 4,
        g.cells.len() as u64 * 4,
        g.live.len() as u64 * 4,
    ]
    .into_iter()
    .max()
    .unwrap_or(0)
}

/// The slot range that holds every live cell: `[first live, last live + 1)`.
fn slot_range(g: &GridBuffers) -> (u32, u32) {
    match (g.live.first(), g.live.last()) {
        (Some(&a), Some(&b)) => (a, b + 1),
        _ => (0, 0),
    }
}

/// Splits `g` into parts whose every buffer holds at most `budget` bytes.
/// One part (`g` itself, slots unchanged) when `g` fits already.
pub fn split_grid(g: GridBuffers, budget: u64) -> Result<Vec<GridPart>, CellTooLarge> {
    if largest_buffer(&g) <= budget {
        return Ok(vec![GridPart {
            buffers: g,
            slot_lo: 0,
            slot_hi: u32::MAX,
        }]);
    }
    if g.structured {
        split_structured(&g, budget)
    } else {
        split_cgraph(&g, budget)
    }
}

/// The buffers shared by every part: kind, catalog and per-part fields
/// left empty.
fn shell(g: &GridBuffers) -> GridBuffers {
    GridBuffers {
        structured: g.structured,
        slab: g.slab,
        hex_meta: g.hex_meta,
        hex_offsets: g.hex_offsets,
        tables: g.tables.clone(),
        sections: g.sections,
        attr_per_cell: g.attr_per_cell,
        ..Default::default()
    }
}

/// The live slots of `[lo, hi)`, made local.
fn local_live(g: &GridBuffers, lo: u32, hi: u32) -> Vec<u32> {
    let a = g.live.partition_point(|&s| s < lo);
    let b = g.live.partition_point(|&s| s < hi);
    g.live[a..b].iter().map(|&s| s - lo).collect()
}

/// S-CGraph: slot s uses vertices `s − slab + offsets`; a part of slots
/// `[lo, hi)` is the vertex window from `lo − slab` and, with `slab = 0`,
/// its local slot is its local first vertex.
fn split_structured(g: &GridBuffers, budget: u64) -> Result<Vec<GridPart>, CellTooLarge> {
    let span = g.hex_offsets.iter().copied().max().unwrap_or(0) as u64 + 1;
    let (first, end) = slot_range(g);
    // Vertices of a part of n slots: n − 1 + span (16 bytes each).
    let per = (budget / 16).saturating_sub(span - 1);
    if per == 0 {
        return Err(CellTooLarge {
            slot: first,
            bytes: span * 16,
            budget,
        });
    }
    let mut parts = Vec::new();
    let mut lo = first;
    while lo < end {
        let hi = (lo as u64 + per).min(end as u64) as u32;
        let v0 = (lo - g.slab) as usize;
        let v1 = ((hi - 1 - g.slab) as u64 + span) as usize;
        let v1 = v1.min(g.grid.len());
        let mut b = shell(g);
        b.slab = 0;
        b.grid = g.grid[v0..v1].to_vec();
        if !g.grad.is_empty() {
            b.grad = g.grad[v0..v1].to_vec();
        }
        b.attr = match (g.attr.is_empty(), g.attr_per_cell) {
            (true, _) => Vec::new(),
            (false, true) => g.attr[lo as usize..hi as usize].to_vec(),
            (false, false) => g.attr[v0..v1].to_vec(),
        };
        b.live = local_live(g, lo, hi);
        parts.push(GridPart {
            buffers: b,
            slot_lo: lo,
            slot_hi: hi,
        });
        lo = hi;
    }
    Ok(parts)
}

/// Vertex ids of the live CGraph cell in `slot` (empty for a dead one).
fn cell_ids<'a>(g: &'a GridBuffers, slot: u32, live: &[bool]) -> &'a [u32] {
    if !live[slot as usize] {
        return &[];
    }
    let m = g.cells[2 * slot as usize];
    let start = g.cells[2 * slot as usize + 1] as usize;
    let nv = g.tables[(g.sections.metas + m * META_WORDS) as usize] as usize;
    &g.cells[start..start + nv]
}

/// CGraph: slots in order, a part closed when one more cell would push
/// its vertices or its cell table over the budget.
fn split_cgraph(g: &GridBuffers, budget: u64) -> Result<Vec<GridPart>, CellTooLarge> {
    let (first, end) = slot_range(g);
    let mut live = vec![false; end as usize];
    for &s in &g.live {
        live[s as usize] = true;
    }
    // seen[v] = 1 + the part that last counted v.
    let mut seen = vec![0u32; g.grid.len()];
    let mut parts = Vec::new();
    let (mut lo, mut verts, mut words) = (first, 0u64, 0u64);
    let mut s = first;
    while s < end {
        let ids = cell_ids(g, s, &live);
        let tag = parts.len() as u32 + 1;
        let new = ids.iter().filter(|&&v| seen[v as usize] != tag).count() as u64;
        let cell_words = 2 + ids.len() as u64;
        let fits = |v: u64, w: u64| {
            v * 16 <= budget && w * 4 <= budget && (s + 1 - lo) as u64 * 4 <= budget
        };
        if fits(verts + new, words + cell_words) {
            for &v in ids {
                seen[v as usize] = tag;
            }
            verts += new;
            words += cell_words;
            s += 1;
            continue;
        }
        if s == lo {
            return Err(CellTooLarge {
                slot: s,
                bytes: (ids.len() as u64 * 16).max(cell_words * 4),
                budget,
            });
        }
        parts.push(cgraph_part(g, lo, s, &live));
        (lo, verts, words) = (s, 0, 0);
    }
    if lo < end {
        parts.push(cgraph_part(g, lo, end, &live));
    }
    Ok(parts)
}

/// The CGraph part of slots `[lo, hi)`: its referenced vertices in global
/// id order, its cell table over local slots and local vertex ids.
fn cgraph_part(g: &GridBuffers, lo: u32, hi: u32, live: &[bool]) -> GridPart {
    // Global id -> local id, numbered in global id order (a dense map: a
    // sort and a binary search per corner were this function's cost).
    const UNUSED: u32 = u32::MAX;
    const USED: u32 = u32::MAX - 1;
    let mut map = vec![UNUSED; g.grid.len()];
    for s in lo..hi {
        for &v in cell_ids(g, s, live) {
            map[v as usize] = USED;
        }
    }
    let mut used: Vec<u32> = Vec::new();
    for (v, m) in map.iter_mut().enumerate() {
        if *m == USED {
            *m = used.len() as u32;
            used.push(v as u32);
        }
    }
    let local = |v: u32| map[v as usize];
    let n = (hi - lo) as usize;
    let mut cells = vec![0u32; 2 * n];
    let mut ids = [0u32; MAX_META_VERTICES];
    for s in lo..hi {
        let gi = cell_ids(g, s, live);
        if gi.is_empty() {
            continue;
        }
        let l = (s - lo) as usize;
        cells[2 * l] = g.cells[2 * s as usize];
        cells[2 * l + 1] = cells.len() as u32;
        for (d, &v) in ids.iter_mut().zip(gi) {
            *d = local(v);
        }
        cells.extend_from_slice(&ids[..gi.len()]);
    }
    let pick = |src: &[[f32; 4]]| -> Vec<[f32; 4]> {
        if src.is_empty() {
            Vec::new()
        } else {
            used.iter().map(|&v| src[v as usize]).collect()
        }
    };
    let mut b = shell(g);
    b.grid = pick(&g.grid);
    b.grad = pick(&g.grad);
    b.attr = match (g.attr.is_empty(), g.attr_per_cell) {
        (true, _) => Vec::new(),
        (false, true) => g.attr[lo as usize..hi as usize].to_vec(),
        (false, false) => used.iter().map(|&v| g.attr[v as usize]).collect(),
    };
    b.cells = cells;
    b.live = local_live(g, lo, hi);
    GridPart {
        buffers: b,
        slot_lo: lo,
        slot_hi: hi,
    }
}

/// The entries of `frame` that fall in each part (given by its global slot
/// range `[slot_lo, slot_hi)`, in order), with local slots (same levels,
/// level order kept).
pub fn split_frame(parts: &[(u32, u32)], frame: &Frame) -> Vec<Frame> {
    let mut out: Vec<Frame> = parts
        .iter()
        .map(|_| Frame {
            levels: frame.levels.clone(),
            entries: Vec::new(),
            visited: frame.visited.clone(),
        })
        .collect();
    for e in &frame.entries {
        let p = parts.partition_point(|q| q.1 <= e.slot);
        if let Some(&(lo, _)) = parts.get(p) {
            out[p].entries.push(Entry {
                slot: e.slot - lo,
                level: e.level,
            });
        }
    }
    out
}
