//! Emission of a level's cut lattice cells, in slot order, welded by edge
//! ownership (or by the mesh's hash map).

use super::weld::{EdgeOwnership, EdgeWindow, HexCell, HexLevel};
use super::writer::HexWriter;
use super::{LatticeSweep, code8, load8};
use crate::extract::{LevelMesh, prefetch};
use crate::sweep::PREFETCH_AHEAD;

/// A level's cut cells as [`emit_cut_cells`] takes them: `cut`, whose
/// slots `slot_of(x)` ascend, in the block of `len` slots from `start`, at
/// level `t`.
pub(crate) struct CutCells<'c, T, S> {
    /// The cut cells.
    pub(crate) cut: &'c [T],
    /// The slot of an entry of `cut`.
    pub(crate) slot_of: S,
    /// The block's first slot.
    pub(crate) start: u32,
    /// The block's slot count.
    pub(crate) len: u32,
    /// The level.
    pub(crate) t: f32,
}

/// Emits the polygons of a level's cut cells `cells` into `mesh`, welded
/// by edge ownership through `window` when `owner` is given, else by the
/// mesh's hash map. With [`crate::extract::EmitContext::cells_only`] it records only the
/// cells.
#[inline(never)]
pub(crate) fn emit_cut_cells<T: Copy>(
    input: &LatticeSweep,
    cells: CutCells<T, impl Fn(T) -> u32>,
    owner: Option<&EdgeOwnership>,
    mesh: &mut LevelMesh,
    window: &mut EdgeWindow,
) {
    let LatticeSweep {
        ref lat, phi, ctx, ..
    } = *input;
    let CutCells {
        cut,
        slot_of,
        start,
        len,
        t,
    } = cells;
    let [di, dj, dk] = lat.deltas;
    if ctx.cells_only {
        mesh.cells.extend(cut.iter().map(|&x| slot_of(x)));
        mesh.cut_cells = cut.len() as u32;
        return;
    }
    // The vertex rows (φ, positions and attribute) of the cell some
    // entries ahead of the n-th.
    let prefetch_ahead = |n: usize| {
        if let Some(&ahead) = cut.get(n + 4 * PREFETCH_AHEAD) {
            let v = slot_of(ahead) - lat.base;
            for r in [v, v + dj, v + dk, v + dj + dk] {
                prefetch(phi, r as usize);
                prefetch(ctx.positions, r as usize);
                if let Some(a) = ctx.attribute {
                    prefetch(a, r as usize);
                }
            }
        }
    };
    // SAFETY (for `load`): `c` is a live cell, whose vertices are <
    // lat.vertices <= phi.len() (checked by the callers).
    let load = |c: u32| unsafe { load8(phi, c - lat.base, dj, dk) };
    let Some(owner) = owner else {
        for (n, &x) in cut.iter().enumerate() {
            prefetch_ahead(n);
            let c = slot_of(x);
            let f = load(c);
            lat.table
                .emit_hashed(lat.meta, (c - lat.base, &f, c), t, ctx, mesh);
        }
        return;
    };
    // The emitter reads the attribute of the cells' vertices unchecked.
    assert!(
        ctx.attribute.is_none_or(|a| a.len() >= lat.vertices),
        "the attribute has fewer values than the lattice has vertices"
    );
    // Every lower neighbour is within this many slots.
    let reach = dk + dj + di;
    // Which earlier edge neighbours of cell c are live cells of this block
    // (they own the edges they share with it): all of them for a
    // surrounded cell away from the block's ends.
    let live_lower = |c: u32| {
        let inner = c.wrapping_sub(start).wrapping_sub(reach) < len.saturating_sub(2 * reach);
        if inner && lat.surrounded.get(c as usize) {
            511
        } else {
            let mut live = 0u32;
            for (n, &step) in owner.lower_steps.iter().enumerate() {
                let j = c.wrapping_add(step).wrapping_sub(start);
                let alive = j < len && lat.live.get(c.wrapping_add(step) as usize);
                live |= (alive as u32) << n;
            }
            live
        }
    };
    // Batches of cells written without capacity checks; a cell with an
    // ambiguous face ends its batch and is written through the mesh.
    let level = HexLevel { t, ctx, owner };
    let mut n = 0;
    while n < cut.len() {
        let batch = (cut.len() - n).min(1024);
        let mut out = HexWriter::new(mesh, batch);
        let end = n + batch;
        let mut ambiguous = None;
        while n < end {
            prefetch_ahead(n);
            let c = slot_of(cut[n]);
            n += 1;
            let f = load(c);
            let cell = HexCell {
                v0: c - lat.base,
                f,
                code: code8(&f, t),
                live: live_lower(c),
                slot: c,
            };
            if !lat.table.emit(&level, &cell, &mut out, window) {
                ambiguous = Some(cell);
                break;
            }
        }
        drop(out);
        if let Some(cell) = ambiguous {
            // A level of its own for the out-of-line call, so that `level`'s
            // address never escapes and its fields stay in registers.
            let level = HexLevel { t, ctx, owner };
            lat.table
                .emit_ambiguous(lat.meta, &level, &cell, mesh, window);
        }
    }
}
