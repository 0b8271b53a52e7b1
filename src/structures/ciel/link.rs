//! CIEL build, after the per-cell phase: the mates across cells (faces
//! bucketed by smallest vertex, matched in parallel) and the vertex cycles
//! (one representative half-edge per fan, grouped by origin).

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use super::{CielError, FIRST_IN_FACE, NONE, VERTEX_MASK};

/// A face as seen by the cross-cell matching: its first half-edge (global),
/// its smallest vertex `m` and the two loop neighbours of `m`, sorted;
/// indexed by [`START`], [`M`], [`LO`], [`HI`] (a plain array, so that the
/// array of all faces is allocated zeroed, without a fill).
pub(super) type FaceRec = [u32; 4];
/// [`FaceRec`]'s first half-edge.
pub(super) const START: usize = 0;
/// [`FaceRec`]'s smallest vertex.
pub(super) const M: usize = 1;
/// [`FaceRec`]'s smaller neighbour of [`M`].
pub(super) const LO: usize = 2;
/// [`FaceRec`]'s larger neighbour of [`M`].
pub(super) const HI: usize = 3;

/// The faces and half-edges the cross-cell phase reads.
pub(super) struct Linked<'a> {
    /// Face records, ordered by first half-edge.
    pub(super) faces: &'a [FaceRec],
    /// Origin of each half-edge (with the face flags).
    pub(super) origins: &'a [u32],
    /// First half-edge of each cell (and the total at the end).
    pub(super) cell_start: &'a [u32],
    /// Half-edges in all.
    pub(super) total: usize,
}

/// What matching the faces of a bucket reads and writes.
struct Matcher<'a> {
    link: &'a Linked<'a>,
    mate_cell: &'a [AtomicU32],
}

impl Matcher<'_> {
    /// The vertex a half-edge leaves.
    #[inline]
    fn org(&self, h: u32) -> u32 {
        self.link.origins[h as usize] & VERTEX_MASK
    }

    /// The half-edges of face `i`.
    #[inline]
    fn loop_of(&self, i: u32) -> std::ops::Range<u32> {
        let faces = self.link.faces;
        let end = faces
            .get(i as usize + 1)
            .map_or(self.link.total as u32, |g| g[START]);
        faces[i as usize][START]..end
    }

    /// Mates the faces of one group `g` of (lo, hi, face) with equal keys.
    fn mate_group(&self, g: &[(u32, u32, u32)]) -> Result<(), CielError> {
        let org = |h: u32| self.org(h);
        // (Two faces of one cell never match: per-cell duplicates are
        // rejected before.)
        if g.len() == 2
            && try_mate(
                self.loop_of(g[0].2),
                self.loop_of(g[1].2),
                org,
                self.mate_cell,
            )
        {
            return Ok(());
        }
        // General case: group the faces by vertex set.
        let mut sets: Vec<(Vec<u32>, u32)> = g
            .iter()
            .map(|x| {
                let r = self.loop_of(x.2);
                let mut s: Vec<u32> = r.clone().map(org).collect();
                s.sort_unstable();
                (s, x.2)
            })
            .collect();
        sets.sort();
        let (faces, cell_start, origins) =
            (self.link.faces, self.link.cell_start, self.link.origins);
        let mut a = 0;
        while a < sets.len() {
            let mut b = a + 1;
            while b < sets.len() && sets[b].0 == sets[a].0 {
                b += 1;
            }
            let bad = |f: u32, why: String| {
                let (cell, face) = locate(cell_start, origins, faces[f as usize][START]);
                CielError::BadSharedFace { cell, face, why }
            };
            match b - a {
                1 => {}
                2 => {
                    let (f, h) = (sets[a].1, sets[a + 1].1);
                    if !try_mate(self.loop_of(f), self.loop_of(h), org, self.mate_cell) {
                        let (oc, of) = locate(cell_start, origins, faces[h as usize][START]);
                        return Err(bad(
                            f,
                            format!(
                                "shared with cell {oc} (face {of}) in the same direction or another vertex order"
                            ),
                        ));
                    }
                }
                k => {
                    return Err(bad(sets[a].1, format!("face shared by {k} cells")));
                }
            }
            a = b;
        }
        Ok(())
    }

    /// Mates the faces bucketed at vertices `vs`.
    fn mate_vertices(
        &self,
        vs: std::ops::Range<usize>,
        bstart: &[u32],
        bucket: &[u32],
    ) -> Result<(), CielError> {
        let mut group: Vec<(u32, u32, u32)> = Vec::new();
        for v in vs {
            let b = &bucket[bstart[v] as usize..bstart[v + 1] as usize];
            if b.len() < 2 {
                continue;
            }
            group.clear();
            group.extend(b.iter().map(|&i| {
                let f = &self.link.faces[i as usize];
                (f[LO], f[HI], i)
            }));
            group.sort_unstable();
            let mut i = 0;
            while i < group.len() {
                let mut j = i + 1;
                while j < group.len() && group[j].0 == group[i].0 && group[j].1 == group[i].1 {
                    j += 1;
                }
                let g = &group[i..j];
                i = j;
                if g.len() >= 2 {
                    self.mate_group(g)?;
                }
            }
        }
        Ok(())
    }
}

impl Linked<'_> {
    /// mate_cell: faces bucketed by smallest vertex (counting sort), the
    /// faces of a bucket with the same key mated; `NONE` on the border.
    /// The first error in vertex order wins.
    pub(super) fn mate_cells(&self, np: usize) -> Result<Vec<u32>, CielError> {
        let (bstart, bucket) = group_by_key(np, &FacesByVertex(self.faces));
        let mate_cell: Vec<AtomicU32> = (0..self.total)
            .into_par_iter()
            .map(|_| AtomicU32::new(NONE))
            .collect();
        let m = Matcher {
            link: self,
            mate_cell: &mate_cell,
        };
        let vchunk = 4096usize;
        let results: Vec<Result<(), CielError>> = (0..np.div_ceil(vchunk))
            .into_par_iter()
            .map(|k| m.mate_vertices(k * vchunk..((k + 1) * vchunk).min(np), &bstart, &bucket))
            .collect();
        for r in results {
            r?;
        }
        drop(bucket);
        drop(bstart);
        Ok(mate_cell.into_iter().map(AtomicU32::into_inner).collect())
    }
}

/// Vertex cycles: representatives (smallest id of each fan), CSR by
/// origin (`vertex_start`, `vertex_edges`).
pub(super) fn vertex_cycles(
    np: usize,
    origins: &[u32],
    mate_face: &[i16],
    mate_cell: &[u32],
) -> (Vec<u32>, Vec<u32>) {
    let total = origins.len();
    let words = total.div_ceil(64);
    let rep_bits: Vec<u64> = (0..words)
        .into_par_iter()
        .map(|w| {
            let mut bits = 0u64;
            for b in 0..64 {
                let h = w * 64 + b;
                if h < total && is_rep(h as u32, mate_face, mate_cell) {
                    bits |= 1 << b;
                }
            }
            bits
        })
        .collect();
    let reps_by_origin = RepsByOrigin {
        bits: &rep_bits,
        origins,
    };
    group_by_key(np, &reps_by_origin)
}

/// Is `h` the smallest half-edge id of its fan?
#[inline]
fn is_rep(h: u32, mate_face: &[i16], mate_cell: &[u32]) -> bool {
    let mf = |x: u32| (x as i64 + mate_face[x as usize] as i64) as u32;
    let limit = mate_cell.len();
    let mut x = h;
    let mut n = 0;
    loop {
        let y = mate_cell[mf(x) as usize];
        if y == h {
            return true;
        }
        if y == NONE {
            break;
        }
        if y < h {
            return false;
        }
        x = y;
        n += 1;
        if n > limit {
            return true;
        }
    }
    // Open fan: the other way from h.
    let mut x = h;
    loop {
        let mc = mate_cell[x as usize];
        if mc == NONE {
            return true;
        }
        x = mf(mc);
        if x < h {
            return false;
        }
        n += 1;
        if n > limit {
            return true;
        }
    }
}

/// Cell and face index (within the cell) of global half-edge `h`, for errors.
fn locate(cell_start: &[u32], origins: &[u32], h: u32) -> (usize, usize) {
    let c = cell_start.partition_point(|&s| s <= h) - 1;
    let f = (cell_start[c]..=h)
        .filter(|&x| origins[x as usize] & FIRST_IN_FACE != 0)
        .count();
    (c, f.saturating_sub(1))
}

/// Items with keys, visited by ranges of units (see [`group_by_key`]).
trait KeyedItems: Sync {
    /// Units to split among tasks (items, or words of a bit set of items).
    fn units(&self) -> usize;
    /// Calls `f(item, key)` for the items of units `r`, in increasing item order.
    fn each(&self, r: std::ops::Range<usize>, f: impl FnMut(u32, u32));
}

/// Faces keyed by their smallest vertex.
struct FacesByVertex<'a>(&'a [FaceRec]);

impl KeyedItems for FacesByVertex<'_> {
    fn units(&self) -> usize {
        self.0.len()
    }
    fn each(&self, r: std::ops::Range<usize>, mut f: impl FnMut(u32, u32)) {
        for i in r.clone() {
            f(i as u32, self.0[i][M]);
        }
    }
}

/// Representative half-edges (a bit set, 64 per word) keyed by origin.
struct RepsByOrigin<'a> {
    bits: &'a [u64],
    origins: &'a [u32],
}

impl KeyedItems for RepsByOrigin<'_> {
    fn units(&self) -> usize {
        self.bits.len()
    }
    fn each(&self, r: std::ops::Range<usize>, mut f: impl FnMut(u32, u32)) {
        for w in r {
            let mut b = self.bits[w];
            while b != 0 {
                let h = w * 64 + b.trailing_zeros() as usize;
                b &= b - 1;
                f(h as u32, self.origins[h] & VERTEX_MASK);
            }
        }
    }
}

/// Items grouped by key, as a stable counting sort run in parallel: unit
/// ranges are counted per key, each range's offsets follow from a prefix
/// sum over keys (in key blocks), then each range places its items. Returns
/// `start` (`keys + 1` offsets) and the item ids, increasing within each
/// key.
fn group_by_key(keys: usize, items: &impl KeyedItems) -> (Vec<u32>, Vec<u32>) {
    let units = items.units();
    let parts = rayon::current_num_threads()
        .clamp(1, 8)
        .min(units.div_ceil(1 << 14).max(1));
    let range = |t: usize| t * units / parts..(t + 1) * units / parts;
    let mut offsets: Vec<Vec<u32>> = (0..parts)
        .into_par_iter()
        .map(|t| {
            let mut count = vec![0u32; keys];
            items.each(range(t), |_, k| count[k as usize] += 1);
            count
        })
        .collect();
    const BLOCK: usize = 1 << 14;
    let block_totals: Vec<u32> = (0..keys.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| {
            let r = b * BLOCK..((b + 1) * BLOCK).min(keys);
            offsets
                .iter()
                .map(|c| c[r.clone()].iter().sum::<u32>())
                .sum()
        })
        .collect();
    let mut acc = 0u32;
    let block_bases: Vec<u32> = block_totals
        .iter()
        .map(|&t| {
            let b = acc;
            acc += t;
            b
        })
        .collect();
    let total = acc;
    let mut start = vec![0u32; keys + 1];
    let mut per_block: Vec<Vec<&mut [u32]>> = block_bases.iter().map(|_| Vec::new()).collect();
    for c in offsets.iter_mut() {
        for (b, s) in c.chunks_mut(BLOCK).enumerate() {
            per_block[b].push(s);
        }
    }
    per_block
        .into_par_iter()
        .zip(start[..keys].par_chunks_mut(BLOCK))
        .zip(block_bases)
        .for_each(|((mut counts, st), mut acc)| {
            for (i, s) in st.iter_mut().enumerate() {
                *s = acc;
                for c in counts.iter_mut() {
                    let n = c[i];
                    c[i] = acc;
                    acc += n;
                }
            }
        });
    start[keys] = total;
    let out: Vec<AtomicU32> = (0..total as usize)
        .into_par_iter()
        .map(|_| AtomicU32::new(0))
        .collect();
    offsets
        .into_par_iter()
        .enumerate()
        .for_each(|(t, mut next)| {
            items.each(range(t), |i, k| {
                let slot = &mut next[k as usize];
                out[*slot as usize].store(i, Ordering::Relaxed);
                *slot += 1;
            });
        });
    (start, out.into_iter().map(AtomicU32::into_inner).collect())
}

/// Mates the half-edges of loops `f` and `g` (global half-edge ranges) if
/// `g` is `f` reversed; returns whether it did.
fn try_mate(
    f: std::ops::Range<u32>,
    g: std::ops::Range<u32>,
    org: impl Fn(u32) -> u32,
    mate_cell: &[AtomicU32],
) -> bool {
    let len = f.end - f.start;
    if g.end - g.start != len {
        return false;
    }
    let v0 = org(f.start);
    let Some(j0) = (g.start..g.end).position(|h| org(h) == v0) else {
        return false;
    };
    let j0 = j0 as u32;
    // Reversed: g[j0 - i] == f[i].
    let mut j = j0;
    for i in 0..len {
        if org(g.start + j) != org(f.start + i) {
            return false;
        }
        j = if j == 0 { len - 1 } else { j - 1 };
    }
    // f_i (f[i] → f[i+1]) mates g's half-edge from f[i+1] to f[i], at j0 - i - 1.
    let mut j = if j0 == 0 { len - 1 } else { j0 - 1 };
    for i in 0..len {
        let (fi, gi) = (f.start + i, g.start + j);
        mate_cell[fi as usize].store(gi, Ordering::Relaxed);
        mate_cell[gi as usize].store(fi, Ordering::Relaxed);
        j = if j == 0 { len - 1 } else { j - 1 };
    }
    true
}
