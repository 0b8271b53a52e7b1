//! The CPU reference of the pre-integration tests: a transfer function
//! and a front-to-back integration along one straight ray.

use stratasweep::gpu::render::Transfer;

/// Orange and faint at 0, blue and dense at 1.
pub fn ramp_transfer() -> Transfer {
    Transfer::from_json(
        r#"{"points":[{"value":0,"color":[1,0.2,0],"opacity":0.05},{"value":1,"color":[0,0.3,1],"opacity":0.95}]}"#,
    )
    .unwrap()
}

/// Front-to-back integration in `n` midpoint steps along a ray of length
/// `len` (unit distance 1); `value(s)` is the value at the fraction `s`
/// of the way from the ray's start.
pub fn integrate_ray(t: &Transfer, n: usize, len: f64, value: impl Fn(f64) -> f64) -> [f64; 4] {
    let ds = len / n as f64;
    let mut acc = [0f64; 4];
    for i in 0..n {
        let s = (i as f64 + 0.5) / n as f64;
        let c = t.eval(value(s));
        let a = 1.0 - (1.0 - c[3] as f64).powf(ds);
        let k = (1.0 - acc[3]) * a;
        for ch in 0..3 {
            acc[ch] += k * c[ch] as f64;
        }
        acc[3] += k;
    }
    acc
}

/// [`integrate_ray`] in 20,000 steps along a ray of length `len` on which
/// the value goes linearly from `v0` to `v1`.
pub fn integrate_linear(t: &Transfer, v0: f64, v1: f64, len: f64) -> [f64; 4] {
    integrate_ray(t, 20_000, len, |s| v0 + (v1 - v0) * s)
}
