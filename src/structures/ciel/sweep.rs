//! The edge-based CIEL sweep and the CIEL brute force.

use rayon::prelude::*;

use super::{Ciel, DrawLevel, DrawScratch, NONE};
use crate::cellgraph::BitSet;
use crate::extract::LevelStats;
use crate::extract::{EmitContext, LevelMesh, intersects};
use crate::field::ScalarField;

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
    /// Edge queues: (representative half-edge, its destination).
    work: Vec<(u32, u32)>,
    active: Vec<(u32, u32)>,
    /// Cells to draw at the current level, each with an entry half-edge.
    cells: Vec<(u32, u32)>,
    minima: Vec<u32>,
    scratch: DrawScratch,
    stamp: u32,
    /// φ is planar: convex cells are drawn from their entry half-edge
    /// ([`Ciel::draw_cell_from`]) instead of a scan of all their half-edges.
    planar: bool,
    /// The structure's non-convex cells (drawn by the full scan).
    non_convex: BitSet,
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
            cells: Vec::new(),
            minima: Vec::new(),
            scratch: DrawScratch::default(),
            stamp: 0,
            planar: false,
            non_convex: {
                let mut b = BitSet::new(ciel.cell_count());
                for &x in ciel.non_convex_cells() {
                    b.set(x as usize);
                }
                b
            },
        }
    }

    /// Finds the minima (vertices with no lower neighbour, by key (φ, id)),
    /// sorted by key; returns their count.
    pub fn prepare_minima<F: ScalarField>(&mut self, f: &F) -> usize {
        self.minima = minima(self.ciel, f);
        self.minima.len()
    }

    /// Declares φ planar (a family of parallel planes): every convex cell
    /// then has one polygon per level, traced from the entry half-edge the
    /// sweep reaches it by (cells the build found non-convex keep the full
    /// scan). Property fields (several polygons per cell) must leave this off.
    pub fn set_planar(&mut self, planar: bool) {
        self.planar = planar;
    }

    /// Uses minima computed once by [`minima`] (shared by parallel sweeps).
    pub fn set_minima(&mut self, minima: Vec<u32>) {
        self.minima = minima;
    }

    /// Bytes of sweep state.
    pub fn state_bytes(&self) -> usize {
        self.cell_stamp.len() * 4
            + self.passed.bytes()
            + (self.work.capacity() + self.active.capacity()) * 8
            + (self.cells.capacity() + self.minima.capacity()) * 4
            + self.scratch.bytes()
            + self.non_convex.bytes()
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
        on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
    ) {
        self.sweep_after(f, None, levels, ctx, mesh, on_level)
    }

    /// [`CielSweeper::sweep`] of the levels that follow level `prev` in a
    /// longer sweep: the state the sweep would have after `prev` (vertices
    /// below it passed, the edges crossing it queued) is rebuilt by one scan
    /// of the vertices, so disjoint ranges of levels can be swept apart and
    /// draw exactly the cells and polygons of the whole sweep.
    pub fn sweep_after<F: ScalarField>(
        &mut self,
        f: &F,
        prev: Option<f32>,
        levels: &[f32],
        ctx: &EmitContext,
        mesh: &mut LevelMesh,
        mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
    ) {
        let c = self.ciel;
        self.passed = BitSet::new(c.positions.len());
        self.active.clear();
        let mut next_min = 0;
        if let Some(tp) = prev {
            for v in 0..c.positions.len() as u32 {
                let fv = f.phi(v);
                let around = c.around_vertex(v);
                if fv >= tp || around.is_empty() {
                    continue;
                }
                self.passed.set(v as usize);
                for &h in around {
                    let w = c.dest(h);
                    let fw = f.phi(w);
                    if fw >= tp && key_below(fv, v, fw, w) {
                        self.active.push((h, w));
                    }
                }
            }
            next_min = self.minima.partition_point(|&m| f.phi(m) < tp);
        }
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
                let (h, b) = self.work[i];
                i += 1;
                if f.phi(b) >= t {
                    self.active.push((h, b));
                } else {
                    Self::pass(c, f, &mut self.passed, &mut self.work, b);
                }
            }
            let visited = self.work.len() as u64;
            self.work.clear();
            // Draw the cells around the active edges, once each: the cell
            // of each active edge seeds a walk across the faces its polygons
            // cross (`mate_cell`), which reaches every cell around the edge
            // (they share faces holding the edge, which the level crosses).
            // Depth first: a neighbour is drawn right after the cell that
            // found it, while their shared vertices are still in cache.
            let stamps = &mut self.cell_stamp;
            let stamp = self.stamp;
            let cells = &mut self.cells;
            let planar = self.planar;
            let all_convex = self.ciel.non_convex_cells().is_empty();
            let non_convex = &self.non_convex;
            for &(h, _) in &self.active {
                let cell = c.cell_of(h);
                if stamps[cell as usize] == stamp {
                    continue;
                }
                stamps[cell as usize] = stamp;
                // h runs from below to above: its mate in the adjacent face
                // of the same cell is an entry half-edge.
                cells.push((cell, c.mate_face(h)));
                while let Some((x, seed)) = cells.pop() {
                    // An entry e of x crossed into mate_cell(e), which
                    // leaves it by the mate; that mate's mate_face enters.
                    let visit = |e: u32| {
                        let m = c.mate_cell(e);
                        if m != NONE {
                            let y = c.cell_of(m);
                            if stamps[y as usize] != stamp {
                                stamps[y as usize] = stamp;
                                cells.push((y, c.mate_face(m)));
                            }
                        }
                    };
                    let lv = DrawLevel { f, t, ctx };
                    if planar && (all_convex || !non_convex.get(x as usize)) {
                        c.draw_cell_from(&lv, x, seed, &mut self.scratch, mesh, visit);
                    } else {
                        c.draw_cell(&lv, x, &mut self.scratch, mesh, visit);
                    }
                }
            }
            let st = LevelStats::of(mesh, visited);
            on_level(k, mesh, &st);
        }
    }

    /// Passes vertex `v` (φ(v) < t): pushes its upward edges, once per sweep.
    #[inline(always)]
    fn pass<F: ScalarField>(
        c: &Ciel,
        f: &F,
        passed: &mut BitSet,
        work: &mut Vec<(u32, u32)>,
        v: u32,
    ) {
        if passed.get(v as usize) {
            return;
        }
        passed.set(v as usize);
        let fv = f.phi(v);
        for &h in c.around_vertex(v) {
            let w = c.dest(h);
            if key_below(fv, v, f.phi(w), w) {
                work.push((h, w));
            }
        }
    }
}

/// The minima of `f` over a [`Ciel`]: live vertices with no lower
/// neighbour by key (φ, id), sorted by key.
pub fn minima<F: ScalarField>(c: &Ciel, f: &F) -> Vec<u32> {
    let mut m: Vec<u32> = (0..c.positions.len() as u32)
        .into_par_iter()
        .filter(|&v| {
            let around = c.around_vertex(v);
            if around.is_empty() {
                return false;
            }
            let fv = f.phi(v);
            around.iter().all(|&h| {
                let w = c.dest(h);
                !key_below(f.phi(w), w, fv, v)
            })
        })
        .collect();
    m.sort_unstable_by(|&a, &b| f.phi(a).total_cmp(&f.phi(b)).then(a.cmp(&b)));
    m
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
        let lv = DrawLevel { f, t, ctx };
        for &(x, lo, hi) in &live {
            if intersects(lo, hi, t) {
                c.draw_cell(&lv, x, &mut scratch, mesh, |_| {});
            }
        }
        let st = LevelStats::of(mesh, live.len() as u64);
        on_level(k, mesh, &st);
    }
}
