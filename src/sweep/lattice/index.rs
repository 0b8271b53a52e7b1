//! The chunked loop's arithmetic: [`LevelIndex`], the level count below a
//! value for 64 values at a time, and [`Divisor`], division by a fixed
//! `u32` through one multiplication.

/// `#{t in levels : t <= x}` (the index of the first level above x), for
/// ascending levels, 64 values at a time: a guess from the levels' mean
/// spacing (vectorised), moved by at most one level and checked against
/// the levels around it; values whose check fails (unevenly spaced levels)
/// take a binary search.
pub(super) struct LevelIndex<'a> {
    levels: &'a [f32],
    /// The levels between −∞ and +∞ sentinels: the count c of x has
    /// `padded[c] <= x < padded[c + 1]`.
    padded: Vec<f32>,
    first: f32,
    inv_step: f32,
}

impl<'a> LevelIndex<'a> {
    pub(super) fn new(levels: &'a [f32]) -> Self {
        let n = levels.len();
        let span = levels[n - 1] - levels[0];
        let inv_step = if n > 1 && span > 0.0 && ((n - 1) as f32 / span).is_finite() {
            (n - 1) as f32 / span
        } else {
            0.0
        };
        let mut padded = Vec::with_capacity(n + 2);
        padded.push(f32::NEG_INFINITY);
        padded.extend_from_slice(levels);
        padded.push(f32::INFINITY);
        LevelIndex {
            levels,
            padded,
            first: levels[0],
            inv_step,
        }
    }

    /// `out[p]` = the count of `xs[p]` (finite values, or ±∞).
    #[inline(always)]
    pub(super) fn count_le_64(&self, xs: &[f32; 64], out: &mut [u8]) {
        let n = self.levels.len();
        let nf = n as f32;
        let mut guess = [0u32; 64];
        for (g, &x) in guess.iter_mut().zip(xs) {
            // f32::max/min drop a NaN ((±∞ − ±∞)·0): the guess is then 0.
            let y = ((x - self.first) * self.inv_step + 1.0).max(0.0).min(nf);
            // SAFETY: y is finite and in 0..=n (< 256).
            *g = unsafe { y.to_int_unchecked::<u32>() };
        }
        let p = &self.padded[..];
        debug_assert_eq!(p.len(), n + 2);
        let mut all_ok = true;
        for ((o, &x), &g) in out.iter_mut().zip(xs).zip(&guess) {
            let mut c = g as usize;
            // SAFETY: c <= n, so c + 1 <= n + 1 < p.len(); after the moves
            // c stays in 0..=n (p[n + 1] = +∞ is only <= x = +∞, then c is
            // clamped; p[0] = −∞ is never > x).
            unsafe {
                c += (*p.get_unchecked(c + 1) <= x) as usize;
                c = c.min(n);
                c -= (*p.get_unchecked(c) > x) as usize;
                all_ok &= *p.get_unchecked(c) <= x && (x < *p.get_unchecked(c + 1) || c == n);
            }
            *o = c as u8;
        }
        if !all_ok {
            for (o, &x) in out.iter_mut().zip(xs) {
                *o = self.levels.partition_point(|&t| t <= x) as u8;
            }
        }
    }
}

/// Division by a fixed `u32` through one multiplication (Lemire, Kaser and
/// Kurz, "Faster remainder by direct computation", 2019): `⌊n / d⌋ =
/// ⌊M·n / 2⁶⁴⌋` with `M = ⌊2⁶⁴ / d⌋ + 1`, exact for every u32 `n`. The
/// patch arithmetic runs per cut patch per step, where a hardware
/// division would cost tens of cycles.
#[derive(Clone, Copy, Debug)]
pub(super) struct Divisor {
    d: u32,
    m: u128,
}

impl Divisor {
    pub(super) fn new(d: u32) -> Self {
        assert!(d > 0, "division by zero");
        Divisor {
            d,
            m: (1u128 << 64) / d as u128 + 1,
        }
    }

    /// `(n / d, n % d)`.
    #[inline(always)]
    pub(super) fn div_rem(&self, n: u32) -> (u32, u32) {
        let q = ((self.m * n as u128) >> 64) as u32;
        (q, n - q * self.d)
    }
}

#[cfg(test)]
mod tests {
    use super::{Divisor, LevelIndex};

    /// The multiply-shift division equals `/` and `%` for small, large and
    /// random divisors and dividends, u32::MAX included.
    #[test]
    fn divisor_equals_hardware_division() {
        let mut x = 0x9E37_79B9u32;
        let mut rnd = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        let mut divisors = vec![1, 2, 3, 7, 17, 33, 64, 65, 1000, u32::MAX - 1, u32::MAX];
        divisors.extend((0..50).map(|_| rnd() % 5000 + 1));
        divisors.extend((0..50).map(|_| rnd().max(1)));
        for d in divisors {
            let by = Divisor::new(d);
            let mut ns = vec![0, 1, d - 1, d, d.wrapping_add(1), u32::MAX, u32::MAX - 1];
            ns.extend((0..2000).map(|_| rnd()));
            ns.extend((0..200).map(|_| rnd() % 100_000));
            for n in ns {
                assert_eq!(by.div_rem(n), (n / d, n % d), "{n} / {d}");
            }
        }
    }

    /// The batched level index equals a binary search over the levels, for
    /// evenly and unevenly spaced levels, values on, between and outside
    /// the levels, and ±∞.
    #[test]
    fn level_index_equals_the_binary_search() {
        let mut x = 0x1234_5678u32;
        let mut rnd = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        let even: Vec<f32> = (0..200).map(|k| -3.7 + k as f32 * 0.031).collect();
        let uneven: Vec<f32> = (0..50).map(|k| (k * k) as f32 * 0.01 - 2.0).collect();
        let single = vec![0.5f32];
        let tight: Vec<f32> = (0..255).map(|k| 1000.0 + k as f32 * 0.000_1).collect();
        for levels in [even, uneven, single, tight] {
            let index = LevelIndex::new(&levels);
            for round in 0..200 {
                let xs: [f32; 64] = std::array::from_fn(|p| match (round + p) % 5 {
                    // A level itself, or its neighbours in f32.
                    0 => levels[rnd() as usize % levels.len()],
                    1 => f32::from_bits(levels[rnd() as usize % levels.len()].to_bits() + 1),
                    2 => f32::from_bits(levels[rnd() as usize % levels.len()].to_bits() - 1),
                    3 if p % 17 == 0 => [f32::INFINITY, f32::NEG_INFINITY][p % 2],
                    _ => {
                        let (a, b) = (levels[0], levels[levels.len() - 1]);
                        a - 1.0 + (b - a + 2.0) * (rnd() % 10_000) as f32 / 10_000.0
                    }
                });
                let mut got = [0u8; 64];
                index.count_le_64(&xs, &mut got);
                for (p, &x) in xs.iter().enumerate() {
                    let want = levels.partition_point(|&t| t <= x);
                    assert_eq!(
                        got[p] as usize,
                        want,
                        "x = {x} among {} levels",
                        levels.len()
                    );
                }
            }
        }
    }
}
