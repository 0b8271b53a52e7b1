//! The reference: tests every cell against every level with the same tie
//! rule and the same polygon code as the sweep. O(N·K), used to check the
//! structures and to benchmark against.

use crate::extract::{CutCell, EmitContext, LevelMesh, code_of, emit_cell, intersects};
use crate::field::ScalarField;
use crate::metacell::MAX_META_VERTICES;
use crate::sweep::{CellGraph, LevelStats, NEVER};

/// Extracts every level by testing every cell, in slot order. `on_level` is
/// called once per level with the reused buffer `mesh` and its statistics.
pub fn brute_force<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    levels: &[f32],
    ctx: &EmitContext,
    mesh: &mut LevelMesh,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let valid: Vec<u32> = g
        .initial_stamps()
        .iter()
        .enumerate()
        .filter(|(_, s)| **s != NEVER)
        .map(|(i, _)| i as u32)
        .collect();
    let catalog = g.catalog();
    let mut ids = [0u32; MAX_META_VERTICES];
    let mut phi = [0f32; MAX_META_VERTICES];
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        for &c in &valid {
            let (m, n) = g.cell(c, &mut ids);
            let mut lo = f32::INFINITY;
            let mut hi = f32::NEG_INFINITY;
            for i in 0..n {
                phi[i] = f.phi(ids[i]);
                lo = lo.min(phi[i]);
                hi = hi.max(phi[i]);
            }
            if intersects(lo, hi, t) {
                let cell = CutCell {
                    gids: &ids[..n],
                    phi: &phi[..n],
                    t,
                    code: code_of(&phi[..n], t),
                    slot: c,
                };
                emit_cell(catalog.get(m), &cell, ctx, mesh);
            }
        }
        let stats = LevelStats::of(mesh, valid.len() as u64);
        on_level(k, mesh, &stats);
    }
}
