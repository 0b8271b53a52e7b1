//! The edge-based CIEL sweep and the CIEL brute force.

use rayon::prelude::*;

use super::{Ciel, DrawScratch};
use crate::extract::{EmitContext, LevelMesh, intersects};
use crate::field::ScalarField;
use crate::structure::BitSet;
use crate::sweep::LevelStats;

/// Is vertex `a`'s key `(φ, id)` below `b`'s?
#[inline(always)]
fn key_below(fa: f32, a: u32, fb: f32, b: u32) -> bool {
    fa < fb || (fa == fb && a < b)
}

/// Sweep state over a [`Ciel`]: the two edge queues, vertex and cell stamps, minima.
pub struct CielSweeper<'c> {
    ciel: &'c Ciel,
    /// Per cell: the last level stamp it was drawn at.
    cell_stamp: Vec<u32>,
    /// Vertices passed in this sweep.
    passed: BitSet,
    work: Vec<u32>,
    active: Vec<u32>,
    minima: Vec<u32>,
    scratch: DrawScratch,
    stamp: u32,
}

impl<'c> CielSweeper<'c> {
    /// New sweep state for `ciel`.
    pub fn new(ciel: &'c Ciel) -> Self {
        CielSweeper {
            ciel,
            cell_stamp: vec![0; ciel.cell_count()],
            passed: BitSet::new(ciel.positions.len()),
            work: Vec::new(),
            active: Vec::new(),
            minima: Vec::new(),
            scratch: DrawScratch::default(),
            stamp: 0,
        }
    }

    /// Finds the minima (vertices with no lower neighbour, by key (φ, id)),
    /// sorted by key; returns their count.
    pub fn prepare_minima<F: ScalarField>(&mut self, f: &F) -> usize {
        let c = self.ciel;
        let mut m: Vec<u32> = (0..c.positions.len() as u32)
            .into_par_iter()
            .filter(|&v| {
                if c.around_vertex(v).is_empty() {
                    return false;
                }
                let fv = f.phi(v);
                let mut min = true;
                c.for_each_around_vertex(v, |h| {
                    let w = c.dest(h);
                    if key_below(f.phi(w), w, fv, v) {
                        min = false;
                    }
                });
                min
            })
            .collect();
        m.sort_unstable_by(|&a, &b| f.phi(a).total_cmp(&f.phi(b)).then(a.cmp(&b)));
        self.minima = m;
        self.minima.len()
    }

    /// Bytes of sweep state.
    pub fn state_bytes(&self) -> usize {
        self.cell_stamp.len() * 4
            + self.passed.bytes()
            + (self.work.capacity() + self.active.capacity() + self.minima.capacity()) * 4
            + self.scratch.used.capacity() * 9
    }

    /// Sweeps `levels` (increasing, local frame); calls `on_level` with each
    /// level's mesh and statistics (`visited` counts the edges popped).
    /// [`CielSweeper::prepare_minima`] must have been called with `f`.
    pub fn sweep<F: ScalarField>(
        &mut self,
        f: &F,
        levels: &[f32],
        ctx: &EmitContext,
        mesh: &mut LevelMesh,
        mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
    ) {
        let c = self.ciel;
        self.passed = BitSet::new(c.positions.len());
        self.active.clear();
        let mut next_min = 0;
        for (k, &t) in levels.iter().enumerate() {
            mesh.clear();
            self.stamp = self.stamp.wrapping_add(1);
            if self.stamp == 0 {
                self.cell_stamp.fill(0);
                self.stamp = 1;
            }
            std::mem::swap(&mut self.work, &mut self.active);
            self.active.clear();
            // Minima passed by this level.
            while next_min < self.minima.len() && f.phi(self.minima[next_min]) < t {
                let v = self.minima[next_min];
                next_min += 1;
                Self::pass(c, f, &mut self.passed, &mut self.work, v);
            }
            let mut i = 0;
            while i < self.work.len() {
                let h = self.work[i];
                i += 1;
                let b = c.dest(h);
                if f.phi(b) >= t {
                    self.active.push(h);
                } else {
                    Self::pass(c, f, &mut self.passed, &mut self.work, b);
                }
            }
            let visited = self.work.len() as u64;
            self.work.clear();
            // Draw the cells around the active edges, once each.
            for &h in &self.active {
                c.for_each_cell_around_edge(h, |x| {
                    let cell = c.cell_of(x);
                    if self.cell_stamp[cell as usize] != self.stamp {
                        self.cell_stamp[cell as usize] = self.stamp;
                        c.draw_cell(f, cell, t, ctx, &mut self.scratch, mesh);
                    }
                });
            }
            let st = LevelStats::of(mesh, visited);
            on_level(k, mesh, &st);
        }
    }

    /// Passes vertex `v` (φ(v) < t): pushes its upward edges, once per sweep.
    #[inline(always)]
    fn pass<F: ScalarField>(c: &Ciel, f: &F, passed: &mut BitSet, work: &mut Vec<u32>, v: u32) {
        if passed.get(v as usize) {
            return;
        }
        passed.set(v as usize);
        let fv = f.phi(v);
        c.for_each_around_vertex(v, |h| {
            let w = c.dest(h);
            if key_below(fv, v, f.phi(w), w) {
                work.push(h);
            }
        });
    }
}

/// The reference over a [`Ciel`]: every live cell against every level with
/// the same tie rule and the same drawing code.
pub fn brute_force<F: ScalarField>(
    c: &Ciel,
    f: &F,
    levels: &[f32],
    ctx: &EmitContext,
    mesh: &mut LevelMesh,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let live: Vec<(u32, f32, f32)> = (0..c.cell_count() as u32)
        .filter(|&x| c.is_live(x))
        .map(|x| {
            let mut lo = f32::INFINITY;
            let mut hi = f32::NEG_INFINITY;
            for h in c.cell_half_edges(x) {
                let p = f.phi(c.org(h));
                lo = lo.min(p);
                hi = hi.max(p);
            }
            (x, lo, hi)
        })
        .collect();
    let mut scratch = DrawScratch::default();
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        for &(x, lo, hi) in &live {
            if intersects(lo, hi, t) {
                c.draw_cell(f, x, t, ctx, &mut scratch, mesh);
            }
        }
        let st = LevelStats::of(mesh, live.len() as u64);
        on_level(k, mesh, &st);
    }
}
