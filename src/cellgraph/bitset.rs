//! [`BitSet`]: one bit per slot.

use rayon::prelude::*;

/// A fixed-size bit set (1 bit per slot).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BitSet {
    words: Vec<u64>,
}

impl BitSet {
    /// `n` cleared bits.
    pub fn new(n: usize) -> Self {
        BitSet {
            words: vec![0; n.div_ceil(64)],
        }
    }
    /// Sets bit `i`.
    #[inline]
    pub fn set(&mut self, i: usize) {
        self.words[i >> 6] |= 1 << (i & 63);
    }
    /// Reads bit `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> bool {
        self.words
            .get(i >> 6)
            .is_some_and(|w| w >> (i & 63) & 1 == 1)
    }
    /// Bits `start..start + 64` as one word (bits outside the set read 0).
    #[inline]
    pub fn word_at(&self, start: i64) -> u64 {
        let w = start.div_euclid(64);
        let r = start.rem_euclid(64) as u32;
        let word = |i: i64| {
            usize::try_from(i)
                .ok()
                .and_then(|i| self.words.get(i))
                .copied()
                .unwrap_or(0)
        };
        if r == 0 {
            word(w)
        } else {
            word(w) >> r | word(w + 1) << (64 - r)
        }
    }
    /// The bits set here whose every `i + step` (for each step) is set too.
    pub fn with_all_set_at(&self, steps: &[i64]) -> BitSet {
        let words = (0..self.words.len())
            .into_par_iter()
            .map(|w| {
                let at = 64 * w as i64;
                steps
                    .iter()
                    .fold(self.words[w], |acc, &d| acc & self.word_at(at + d))
            })
            .collect();
        BitSet { words }
    }
    /// Number of set bits.
    pub fn count(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.words.len() * 8
    }
}
