//! Transfer functions (no wgpu): control points, the named colormaps,
//! JSON parsing with readable errors, evaluation, the lookup table the
//! render pass reads, and the checks that refuse a transfer function that
//! can only draw nothing.
//!
//! The lookup table is the transfer function restricted to the data's
//! range: its knots are the range's ends and every control point inside
//! the range, at their exact positions, so a control point far outside
//! the data does not squeeze the data into one entry and a narrow spike
//! inside the data is kept. The shader finds a value's knot interval by
//! binary search (`transfer` in `wgsl/shared/draw.wgsl`).

use serde_json::Value;
use thiserror::Error;

/// Knots the lookup table holds (`LUT_KNOTS` in `wgsl/shared/draw.wgsl`): the
/// data range's two ends and up to [`MAX_POINTS`] control points.
pub const LUT_KNOTS: usize = 1024;

/// Control points a transfer function may have.
pub const MAX_POINTS: usize = LUT_KNOTS - 2;

/// `vec4<f32>` entries of the lookup table buffer: a header (knot count),
/// the knots' RGBA, then their positions four to an entry.
pub const LUT_VEC4S: usize = 1 + LUT_KNOTS + LUT_KNOTS / 4;

/// The largest magnitude a shown value or knot position takes on the GPU:
/// values beyond it (up to ±f64::MAX, or infinite in f32) are clamped to
/// it, so that interpolating between two of them (`a + t·(b − a)`, and
/// the rasteriser's weights) stays finite in f32.
pub const VALUE_LIMIT: f32 = f32::MAX / 4.0;

const F32_MAX: f64 = VALUE_LIMIT as f64;

/// Errors of transfer functions.
#[derive(Debug, Error)]
pub enum TransferError {
    /// The text is not JSON.
    #[error("transfer function JSON: {0}")]
    Syntax(String),
    /// The JSON is not a transfer function.
    #[error(
        "transfer function: {0} (expected {{\"points\": [{{\"value\": v, \"color\": [r, g, b], \"opacity\": a}}, ...]}})"
    )]
    Shape(String),
    /// A control point is out of range or malformed.
    #[error("transfer function, point {index}: {why}")]
    Point {
        /// The point's index in the file (from 0).
        index: usize,
        /// What is wrong.
        why: String,
    },
    /// Neither a colormap name nor a JSON file.
    #[error(
        "'{0}' is neither a colormap name ({names}) nor a transfer-function file (a path ending in .json)",
        names = COLORMAPS.join(", ")
    )]
    NotATransfer(String),
    /// The transfer function can only draw nothing.
    #[error("{0}")]
    Blank(String),
}

/// One control point of a transfer function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransferPoint {
    /// Property value.
    pub value: f64,
    /// Straight RGB in [0, 1].
    pub color: [f32; 3],
    /// Opacity per unit distance in [0, 1].
    pub opacity: f32,
}

/// A piecewise-linear transfer function (clamped outside its points).
#[derive(Clone, Debug, PartialEq)]
pub struct Transfer {
    /// Control points, sorted by value.
    pub points: Vec<TransferPoint>,
}

/// Where a transfer function comes from: a colormap name or a JSON file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TransferSource {
    /// One of [`COLORMAPS`].
    Colormap(String),
    /// A path ending in `.json` (any case).
    File(String),
}

impl TransferSource {
    /// A colormap name, else a path ending in `.json`; anything else is
    /// refused naming both possibilities (a file named otherwise is not
    /// read as a colormap name).
    pub fn parse(s: &str) -> Result<Self, TransferError> {
        if COLORMAPS.contains(&s) {
            Ok(TransferSource::Colormap(s.into()))
        } else if s.to_ascii_lowercase().ends_with(".json") {
            Ok(TransferSource::File(s.into()))
        } else {
            Err(TransferError::NotATransfer(s.into()))
        }
    }
}

/// (position in [0, 1], RGB) anchors of the named colormaps.
fn colormap(name: &str) -> Option<Vec<(f64, [f32; 3])>> {
    let hex = |h: u32| {
        [
            (h >> 16 & 255) as f32 / 255.0,
            (h >> 8 & 255) as f32 / 255.0,
            (h & 255) as f32 / 255.0,
        ]
    };
    let anchors = |c: &[u32]| {
        c.iter()
            .enumerate()
            .map(|(i, &h)| (i as f64 / (c.len() - 1) as f64, hex(h)))
            .collect()
    };
    Some(match name {
        "viridis" => anchors(&[0x440154, 0x3b528b, 0x21918c, 0x5ec962, 0xfde725]),
        "magma" => anchors(&[0x000004, 0x51127c, 0xb73779, 0xfc8961, 0xfcfdbf]),
        "coolwarm" => anchors(&[0x3b4cc0, 0x8db0fe, 0xdddddd, 0xf49a7b, 0xb40426]),
        "greys" => anchors(&[0xffffff, 0x000000]),
        _ => return None,
    })
}

/// Names accepted by [`Transfer::named`].
pub const COLORMAPS: [&str; 4] = ["viridis", "magma", "coolwarm", "greys"];

/// `[lo, hi]` as finite f32-representable values (`lo ≤ hi`; `(0, 1)`
/// when neither end is a number).
fn finite_range(lo: f64, hi: f64) -> (f64, f64) {
    let c = |x: f64, d: f64| {
        if x.is_nan() {
            d
        } else {
            x.clamp(-F32_MAX, F32_MAX)
        }
    };
    let (lo, hi) = (c(lo, c(hi, 0.0)), c(hi, c(lo, 1.0)));
    if lo <= hi { (lo, hi) } else { (hi, lo) }
}

/// `(v − a) / (b − a)` in [0, 1] without overflow for ends near ±f64::MAX.
fn fraction(v: f64, a: f64, b: f64) -> f64 {
    let f = (v * 0.5 - a * 0.5) / (b * 0.5 - a * 0.5);
    if f.is_nan() { 1.0 } else { f.clamp(0.0, 1.0) }
}

impl Transfer {
    /// A named colormap over `[lo, hi]` with opacity rising linearly from 0
    /// to 1 (a range beyond f32 is clamped to it; a range with no number
    /// taken as `[0, 1]`).
    pub fn named(name: &str, lo: f64, hi: f64) -> Option<Self> {
        let a = colormap(name)?;
        let (lo, hi) = finite_range(lo, hi);
        Some(Transfer {
            points: a
                .into_iter()
                .map(|(x, color)| TransferPoint {
                    value: match hi - lo {
                        w if w.is_finite() => lo + x * w,
                        _ => lo * (1.0 - x) + hi * x,
                    },
                    color,
                    opacity: x as f32,
                })
                .collect(),
        })
    }

    /// Parses `{"points":[{"value":v,"color":[r,g,b],"opacity":a},...]}`
    /// (a leading UTF-8 byte-order mark is skipped). Errors name the point
    /// and the field, never a Rust structure.
    pub fn from_json(text: &str) -> Result<Self, TransferError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let root: Value =
            serde_json::from_str(text).map_err(|e| TransferError::Syntax(e.to_string()))?;
        let Some(obj) = root.as_object() else {
            return Err(TransferError::Shape(format!(
                "the top level is {}, not an object",
                kind(&root)
            )));
        };
        let Some(points) = obj.get("points") else {
            return Err(TransferError::Shape("no \"points\" key".into()));
        };
        let Some(points) = points.as_array() else {
            return Err(TransferError::Shape(format!(
                "\"points\" is {}, not an array",
                kind(points)
            )));
        };
        if points.len() > MAX_POINTS {
            return Err(TransferError::Shape(format!(
                "{} points; at most {MAX_POINTS} are taken",
                points.len()
            )));
        }
        let mut t = Transfer {
            points: points
                .iter()
                .enumerate()
                .map(|(index, p)| point(p).map_err(|why| TransferError::Point { index, why }))
                .collect::<Result<_, _>>()?,
        };
        t.points.sort_by(|a, b| a.value.total_cmp(&b.value));
        Ok(t)
    }

    /// RGBA at `v` (straight colour), clamped outside the points;
    /// transparent black when there are no points or `v` is NaN.
    pub fn eval(&self, v: f64) -> [f32; 4] {
        let p = &self.points;
        let rgba = |q: &TransferPoint| [q.color[0], q.color[1], q.color[2], q.opacity];
        if p.is_empty() || v.is_nan() {
            return [0.0; 4];
        }
        // The first point at or above v.
        let i = p.partition_point(|q| q.value < v);
        if i == 0 {
            return rgba(&p[0]);
        }
        if i == p.len() {
            return rgba(&p[p.len() - 1]);
        }
        let (a, b) = (&p[i - 1], &p[i]);
        let f = fraction(v, a.value, b.value) as f32;
        let (x, y) = (rgba(a), rgba(b));
        std::array::from_fn(|c| x[c] + f * (y[c] - x[c]))
    }

    /// This transfer function restricted to the data range `[lo, hi]`
    /// (clamped to finite f32 values): the colours at the ends and every
    /// control point strictly inside, at its exact value. Equal to `self`
    /// on `[lo, hi]`; its own range is `[lo, hi]`.
    pub fn over(&self, lo: f64, hi: f64) -> Transfer {
        let (lo, hi) = finite_range(lo, hi);
        let at = |v: f64| {
            let c = self.eval(v);
            TransferPoint {
                value: v,
                color: [c[0], c[1], c[2]],
                opacity: c[3],
            }
        };
        let mut points = vec![at(lo)];
        points.extend(
            self.points
                .iter()
                .filter(|p| lo < p.value && p.value < hi)
                .copied(),
        );
        if hi > lo {
            points.push(at(hi));
        }
        Transfer { points }
    }

    /// The lookup table the render pass reads, for this transfer function
    /// restricted to `[lo, hi]` ([`Transfer::over`]): [`LUT_VEC4S`]
    /// entries (header, RGBA per knot, positions), and the range (finite).
    pub fn lut(&self, lo: f64, hi: f64) -> (Vec<[f32; 4]>, f64, f64) {
        let t = self.over(lo, hi);
        let (lo, hi) = (t.points[0].value, t.points[t.points.len() - 1].value);
        let n = t.points.len().min(LUT_KNOTS);
        let mut out = vec![[0f32; 4]; LUT_VEC4S];
        out[0][0] = n as f32;
        for (i, p) in t.points.iter().take(n).enumerate() {
            out[1 + i] = [p.color[0], p.color[1], p.color[2], p.opacity];
            out[1 + LUT_KNOTS + i / 4][i % 4] = p.value as f32;
        }
        (out, lo, hi)
    }

    /// The largest opacity this transfer function takes on `[lo, hi]`.
    pub fn max_opacity_over(&self, lo: f64, hi: f64) -> f32 {
        self.over(lo, hi)
            .points
            .iter()
            .map(|p| p.opacity)
            .fold(0.0, f32::max)
    }

    /// Refuses a transfer function that can only draw nothing, and warns
    /// when it lies wholly outside the data. `opaque`: the mode draws
    /// opaque surfaces (iso), where opacity is not used. `data`: the
    /// shown values' range and what they are (e.g. "property 'PORO'"), when
    /// known. Returns the warnings.
    pub fn check(
        &self,
        opaque: bool,
        data: Option<((f64, f64), &str)>,
    ) -> Result<Vec<String>, TransferError> {
        let blank = |m: String| Err(TransferError::Blank(m));
        let (Some(first), Some(last)) = (self.points.first(), self.points.last()) else {
            return blank("the transfer function has no points: nothing would be drawn".into());
        };
        if !opaque && self.points.iter().all(|p| p.opacity == 0.0) {
            return blank("every transfer point has opacity 0: nothing would be drawn".into());
        }
        let Some(((lo, hi), what)) = data.filter(|((lo, hi), _)| lo <= hi) else {
            return Ok(Vec::new());
        };
        let span = format!(
            "the transfer function's points ({} .. {}) and {what} ({lo} .. {hi})",
            first.value, last.value
        );
        if !opaque && self.max_opacity_over(lo, hi) == 0.0 {
            return blank(format!(
                "the transfer function has opacity 0 over the whole range of {what} ({lo} .. {hi}): nothing would be drawn ({span})"
            ));
        }
        let mut warnings = Vec::new();
        if last.value < lo || first.value > hi {
            let end = if last.value < lo { last } else { first };
            warnings.push(format!(
                "the transfer function lies wholly outside the data: {span} do not overlap, so every value gets the colour of its point at {}",
                end.value
            ));
        }
        Ok(warnings)
    }
}

/// What a JSON value is, in words.
fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// One control point, or what is wrong with it.
fn point(p: &Value) -> Result<TransferPoint, String> {
    let Some(o) = p.as_object() else {
        return Err(format!(
            "is {}, not an object {{\"value\": v, \"color\": [r, g, b], \"opacity\": a}}",
            kind(p)
        ));
    };
    let field = |name: &str| {
        o.get(name).ok_or_else(|| {
            format!("has no \"{name}\" (it needs \"value\", \"color\" and \"opacity\")")
        })
    };
    let number = |name: &str, v: &Value| {
        v.as_f64()
            .ok_or_else(|| format!("\"{name}\" is {}, not a number", kind(v)))
    };
    let unit = |name: &str, x: f64| match (0.0..=1.0).contains(&x) {
        true => Ok(x as f32),
        false => Err(format!("\"{name}\" is {x}; it must be in [0, 1]")),
    };
    let value = number("value", field("value")?)?;
    if !value.is_finite() {
        return Err(format!("\"value\" is {value}; it must be finite"));
    }
    let c = field("color")?;
    let Some(c) = c.as_array() else {
        return Err(format!("\"color\" is {}, not an array [r, g, b]", kind(c)));
    };
    if c.len() != 3 {
        let hint = if c.len() == 4 {
            "; opacity is not part of the colour: give it as \"opacity\""
        } else {
            ""
        };
        return Err(format!(
            "\"color\" has {} components; it needs 3 (r, g, b in [0, 1]){hint}",
            c.len()
        ));
    }
    let mut color = [0f32; 3];
    for (k, (x, name)) in c
        .iter()
        .zip(["color[0] (red)", "color[1] (green)", "color[2] (blue)"])
        .enumerate()
    {
        color[k] = unit(name, number(name, x)?)?;
    }
    let opacity = unit("opacity", number("opacity", field("opacity")?)?)?;
    Ok(TransferPoint {
        value,
        color,
        opacity,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eval_interpolates_and_clamps() {
        let t = Transfer::from_json(
            r#"{"points":[{"value":1,"color":[0,0,1],"opacity":1},{"value":0,"color":[1,0,0],"opacity":0}]}"#,
        )
        .unwrap();
        assert_eq!(t.eval(-5.0), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(t.eval(5.0), [0.0, 0.0, 1.0, 1.0]);
        assert_eq!(t.eval(0.25), [0.75, 0.0, 0.25, 0.25]);
        assert_eq!(t.eval(f64::NAN), [0.0; 4]);
    }

    #[test]
    fn over_keeps_inner_points_and_the_ends() {
        let t = Transfer::named("greys", 0.0, 4.0).unwrap();
        let o = t.over(1.0, 2.0);
        let v: Vec<f64> = o.points.iter().map(|p| p.value).collect();
        assert_eq!(v, [1.0, 2.0]);
        for x in [1.0, 1.3, 1.9, 2.0] {
            assert_eq!(o.eval(x), t.eval(x));
        }
    }
}
