//! Pre-integrated transfer functions (no wgpu): the colour and opacity of
//! a slab whose value goes linearly from `front` to `back`, integrated
//! along the slab once per (front, back) pair into a `PRE_SIZE²` table
//! (`wgsl/pre_slab.wgsl`'s `fs_pre` reads it bilinearly).
//!
//! The slab is `r` unit distances thick (spacing over unit distance, on the
//! axis); opacities are per unit distance, so `m` sub-steps of a slab get
//! `1 − (1 − α)^(r/m)` each, composited front to back. A slab of constant
//! value gives exactly the plain mode's `1 − (1 − α)^r`.

use crate::gpu::render::transfer::Transfer;

/// Entries per side of the table (`PRE_SIZE` in `wgsl/shared/pre.wgsl`).
pub const PRE_SIZE: usize = 128;

/// Sub-steps per slab.
const STEPS: usize = 48;

/// The table for slabs `r` unit distances thick, over the transfer's own
/// value range (as [`Transfer::lut`]): entry `front + PRE_SIZE × back` is
/// premultiplied RGBA.
pub fn preintegrated_table(t: &Transfer, r: f64) -> Vec<[f32; 4]> {
    let (lo, hi) = match (t.points.first(), t.points.last()) {
        (Some(a), Some(b)) => (a.value, b.value),
        _ => (0.0, 1.0),
    };
    let n = PRE_SIZE;
    // The transfer sampled finely once, with each sub-step's opacity.
    let fine = 4 * n;
    let samples: Vec<[f32; 4]> = (0..fine)
        .map(|i| {
            let mut c = t.eval(lo + (hi - lo) * i as f64 / (fine - 1) as f64);
            c[3] = 1.0 - (1.0 - c[3].clamp(0.0, 1.0)).powf((r / STEPS as f64) as f32);
            c
        })
        .collect();
    let at = |x: f64| -> [f32; 4] {
        let f = x.clamp(0.0, 1.0) * (fine - 1) as f64;
        let i = (f.floor() as usize).min(fine - 2);
        let w = (f - i as f64) as f32;
        std::array::from_fn(|c| samples[i][c] + w * (samples[i + 1][c] - samples[i][c]))
    };
    let mut out = vec![[0f32; 4]; n * n];
    for b in 0..n {
        for f in 0..n {
            let (xf, xb) = (f as f64 / (n - 1) as f64, b as f64 / (n - 1) as f64);
            let mut acc = [0f32; 4];
            for m in 0..STEPS {
                let s = (m as f64 + 0.5) / STEPS as f64;
                let c = at(xf + (xb - xf) * s);
                let k = (1.0 - acc[3]) * c[3];
                for ch in 0..3 {
                    acc[ch] += k * c[ch];
                }
                acc[3] += k;
            }
            out[f + n * b] = acc;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::render::transfer::TransferPoint;

    fn ramp() -> Transfer {
        Transfer {
            points: vec![
                TransferPoint {
                    value: 0.0,
                    color: [1.0, 0.0, 0.0],
                    opacity: 0.0,
                },
                TransferPoint {
                    value: 1.0,
                    color: [0.0, 0.0, 1.0],
                    opacity: 0.8,
                },
            ],
        }
    }

    #[test]
    fn constant_slabs_match_the_plain_opacity_correction() {
        let t = ramp();
        let r = 0.7;
        let tab = preintegrated_table(&t, r);
        for i in [0, 40, 90, PRE_SIZE - 1] {
            let v = i as f64 / (PRE_SIZE - 1) as f64;
            let c = t.eval(v);
            let a = 1.0 - (1.0 - c[3] as f64).powf(r);
            let e = tab[i + PRE_SIZE * i];
            assert!((e[3] as f64 - a).abs() < 2e-3, "{i}: {} vs {a}", e[3]);
            // Premultiplied colour of a constant slab: its colour times its opacity.
            assert!((e[0] as f64 - c[0] as f64 * a).abs() < 2e-3);
        }
    }

    #[test]
    fn a_slab_through_a_ramp_is_the_integral_not_the_front_value() {
        let t = ramp();
        let tab = preintegrated_table(&t, 1.0);
        // Front 0 (transparent), back 1: the opacity integrates 0.8·s over
        // the slab: 1 − exp(∫ ln(1 − 0.8 s) ds) = 1 − exp(−(0.2 ln 0.2 + 0.8)/0.8).
        let want = 1.0 - (-(0.2 * 0.2f64.ln() + 0.8) / 0.8).exp();
        let got = tab[PRE_SIZE * (PRE_SIZE - 1)][3] as f64;
        assert!((got - want).abs() < 5e-3, "{got} vs {want}");
        assert!(tab[0][3] == 0.0);
    }

    /// A transfer with several points and colours, integrated by brute
    /// force straight from `Transfer::eval` (no fine table, 20,000 steps).
    fn brute(t: &Transfer, f: f64, b: f64, r: f64) -> [f64; 4] {
        let n = 20_000;
        let mut acc = [0f64; 4];
        for i in 0..n {
            let s = (i as f64 + 0.5) / n as f64;
            let c = t.eval(f + (b - f) * s);
            let a = 1.0 - (1.0 - c[3] as f64).powf(r / n as f64);
            let k = (1.0 - acc[3]) * a;
            for ch in 0..3 {
                acc[ch] += k * c[ch] as f64;
            }
            acc[3] += k;
        }
        acc
    }

    #[test]
    fn the_table_matches_a_brute_force_integration() {
        let p = |value: f64, color: [f32; 3], opacity: f32| TransferPoint {
            value,
            color,
            opacity,
        };
        let t = Transfer {
            points: vec![
                p(-1.0, [0.1, 0.2, 0.9], 0.0),
                p(0.0, [0.9, 0.9, 0.1], 0.6),
                p(0.5, [0.2, 0.8, 0.3], 0.05),
                p(2.0, [1.0, 0.1, 0.1], 1.0),
            ],
        };
        let n = (PRE_SIZE - 1) as f64;
        for r in [0.1, 0.7, 2.5] {
            let tab = preintegrated_table(&t, r);
            for (fi, bi) in [(0, 127), (127, 0), (20, 60), (60, 20), (43, 43), (5, 100)] {
                let v = |i: usize| -1.0 + 3.0 * i as f64 / n;
                let want = brute(&t, v(fi), v(bi), r);
                let got = tab[fi + PRE_SIZE * bi];
                // 48 midpoint sub-steps: a slab that turns opaque within
                // its first sub-step (r 2.5, opacity 1 in front) takes the
                // colour half a sub-step in.
                let tol = if r > 1.0 { 1e-2 } else { 4e-3 };
                for c in 0..4 {
                    assert!(
                        (got[c] as f64 - want[c]).abs() < tol,
                        "r {r} ({fi}, {bi}) channel {c}: {} vs {}",
                        got[c],
                        want[c]
                    );
                }
            }
        }
    }

    #[test]
    fn two_half_slabs_over_each_other_make_one_slab() {
        // The opacity correction: a slab of r from f to b is its front half
        // (r/2, f to m) over its back half (r/2, m to b).
        let t = ramp();
        let (full, half) = (preintegrated_table(&t, 1.2), preintegrated_table(&t, 0.6));
        for (f, b) in [(0, 126), (126, 0), (30, 90), (100, 40)] {
            let m = (f + b) / 2;
            let (x, y) = (half[f + PRE_SIZE * m], half[m + PRE_SIZE * b]);
            let e = full[f + PRE_SIZE * b];
            for c in 0..4 {
                let o = x[c] + (1.0 - x[3]) * y[c];
                assert!(
                    (o - e[c]).abs() < 3e-3,
                    "({f}, {b}) channel {c}: {o} vs {}",
                    e[c]
                );
            }
        }
    }
}
