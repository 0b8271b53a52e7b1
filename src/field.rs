//! Slicing fields φ over the vertices and the level values to sweep.

use rayon::prelude::*;
use thiserror::Error;

/// A scalar field evaluated per vertex, in the structure's local (rebased) frame.
pub trait ScalarField: Sync {
    /// φ at vertex `v`.
    fn phi(&self, v: u32) -> f32;
    /// φ of every vertex as one array, when the field is stored that way
    /// (lets lattice sweeps read it directly).
    fn values(&self) -> Option<&[f32]> {
        None
    }
}

/// φ(x) = n·(x − origin): a family of parallel planes, in local coordinates.
#[derive(Clone, Copy, Debug)]
pub struct PlaneField<'a> {
    /// Unit normal.
    pub normal: [f32; 3],
    /// Rebased vertex positions.
    pub positions: &'a [[f32; 3]],
}

impl ScalarField for PlaneField<'_> {
    #[inline(always)]
    fn phi(&self, v: u32) -> f32 {
        let p = self.positions[v as usize];
        let n = self.normal;
        // Written as a sum of products in fixed order so that every caller
        // (sweep, brute force, GPU twin) gets bit-identical values.
        p[0] * n[0] + p[1] * n[1] + p[2] * n[2]
    }
}

/// φ(x) = ±x\[axis\]: planes orthogonal to a coordinate axis, in local
/// coordinates. Gives the same values as the equivalent [`PlaneField`].
#[derive(Clone, Copy, Debug)]
pub struct AxisField<'a> {
    /// 0, 1 or 2.
    pub axis: usize,
    /// +1 or −1.
    pub sign: f32,
    /// Rebased vertex positions.
    pub positions: &'a [[f32; 3]],
}

impl ScalarField for AxisField<'_> {
    #[inline(always)]
    fn phi(&self, v: u32) -> f32 {
        self.sign * self.positions[v as usize][self.axis]
    }
}

/// φ = a per-vertex property (isosurfaces).
#[derive(Clone, Copy, Debug)]
pub struct VertexField<'a> {
    /// One value per vertex.
    pub values: &'a [f32],
}

impl ScalarField for VertexField<'_> {
    #[inline(always)]
    fn phi(&self, v: u32) -> f32 {
        self.values[v as usize]
    }
    fn values(&self) -> Option<&[f32]> {
        Some(self.values)
    }
}

/// φ of every vertex `0..n` of `f`, evaluated in parallel: the sweep and the
/// brute force read φ from this array (4 bytes per vertex, contiguous)
/// instead of re-deriving it from positions. Same values, bit for bit, as
/// `f.phi`.
pub fn materialise<F: ScalarField>(f: &F, n: usize) -> Vec<f32> {
    let mut out = crate::mem::huge_vec(n);
    (0..n as u32)
        .into_par_iter()
        .map(|v| f.phi(v))
        .collect_into_vec(&mut out);
    out
}

/// What to slice by, before it is bound to a structure's arrays.
#[derive(Clone, Debug, PartialEq)]
pub enum FieldSpec {
    /// Planes orthogonal to a world axis (0 = x, 1 = y, 2 = z); `negative`
    /// means φ = −coordinate.
    Axis {
        /// 0, 1 or 2.
        axis: usize,
        /// Sweep along the negative direction.
        negative: bool,
    },
    /// Planes with an arbitrary normal (normalised).
    Normal([f64; 3]),
    /// Isosurfaces of a vertex property.
    Property(String),
}

impl FieldSpec {
    /// An axis field from `x`, `y` or `z` (either case), optionally signed
    /// (`-z` sweeps downward); `None` for anything else.
    pub fn parse_axis(s: &str) -> Option<FieldSpec> {
        let (negative, a) = match s.strip_prefix('-') {
            Some(r) => (true, r),
            None => (false, s.strip_prefix('+').unwrap_or(s)),
        };
        let axis = match a {
            "x" | "X" => 0,
            "y" | "Y" => 1,
            "z" | "Z" => 2,
            _ => return None,
        };
        Some(FieldSpec::Axis { axis, negative })
    }
}

impl FieldSpec {
    /// The unit normal of a planar field, or `None` for a property.
    pub fn normal(&self) -> Option<[f64; 3]> {
        match self {
            FieldSpec::Axis { axis, negative } => {
                let mut n = [0.0; 3];
                n[*axis] = if *negative { -1.0 } else { 1.0 };
                Some(n)
            }
            FieldSpec::Normal(n) => {
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                Some(n.map(|c| c / l))
            }
            FieldSpec::Property(_) => None,
        }
    }
    /// Index 0..6 of the six cached axis directions (+x,−x,+y,−y,+z,−z).
    pub fn axis_slot(&self) -> Option<usize> {
        match self {
            FieldSpec::Axis { axis, negative } => Some(axis * 2 + *negative as usize),
            _ => None,
        }
    }
    /// Offset to add to a local φ to get the world value: n·origin for planes, 0 for properties.
    pub fn world_offset(&self, origin: [f64; 3]) -> f64 {
        match self.normal() {
            Some(n) => n[0] * origin[0] + n[1] * origin[1] + n[2] * origin[2],
            None => 0.0,
        }
    }
}

/// Errors in level specifications.
#[derive(Debug, Error, PartialEq)]
pub enum LevelError {
    /// Levels must increase strictly.
    #[error("level values must increase strictly: level {index} = {value} follows {previous}")]
    NotIncreasing {
        /// Index of the offending level.
        index: usize,
        /// Its value.
        value: f64,
        /// The previous value.
        previous: f64,
    },
    /// A NaN or infinite level.
    #[error("level {index} is not finite")]
    NotFinite {
        /// Index.
        index: usize,
    },
    /// No levels at all.
    #[error("no levels to sweep")]
    Empty,
    /// The level list does not fit in memory.
    #[error(transparent)]
    Memory(#[from] crate::mem::AllocError),
}

/// Level values `t_k = lo + (k + 0.5)(hi − lo)/K`.
pub fn levels_by_count(lo: f64, hi: f64, count: usize) -> Vec<f64> {
    by_count(lo, hi, count).collect()
}

/// [`levels_by_count`], or an error when the list does not fit in memory.
pub fn try_levels_by_count(lo: f64, hi: f64, count: usize) -> Result<Vec<f64>, LevelError> {
    let mut v = crate::mem::try_vec(count, "the level values")?;
    v.extend(by_count(lo, hi, count));
    Ok(v)
}

/// The values of [`levels_by_count`].
fn by_count(lo: f64, hi: f64, count: usize) -> impl Iterator<Item = f64> {
    (0..count).map(move |k| lo + (k as f64 + 0.5) * (hi - lo) / count as f64)
}

/// Level values `from, from+step, ...` up to and including `to` (within 1e-9 step).
pub fn levels_by_range(from: f64, to: f64, step: f64) -> Vec<f64> {
    // Callers bound the count first with [`range_level_count`].
    if step.is_nan() || step <= 0.0 || !from.is_finite() || !to.is_finite() || to < from {
        return Vec::new();
    }
    let n = ((to - from) / step + 1e-9).floor() as usize + 1;
    (0..n).map(|k| from + k as f64 * step).collect()
}

/// How many levels [`levels_by_range`] would give, computed without making
/// them (infinite when the range over the step does not fit an f64; 0 for
/// invalid arguments), so callers can refuse an absurd count before
/// allocating it.
pub fn range_level_count(from: f64, to: f64, step: f64) -> f64 {
    if step.is_nan() || step <= 0.0 || !from.is_finite() || !to.is_finite() || to < from {
        return 0.0;
    }
    ((to - from) / step + 1e-9).floor() + 1.0
}

/// Converts world level values to the f32 local frame and checks they
/// increase strictly there too.
pub fn local_levels(world: &[f64], offset: f64) -> Result<Vec<f32>, LevelError> {
    if world.is_empty() {
        return Err(LevelError::Empty);
    }
    let mut out = crate::mem::try_vec(world.len(), "the level values (f32)")?;
    for (i, &w) in world.iter().enumerate() {
        if !w.is_finite() {
            return Err(LevelError::NotFinite { index: i });
        }
        let t = (w - offset) as f32;
        if let Some(&p) = out.last()
            && t <= p
        {
            return Err(LevelError::NotIncreasing {
                index: i,
                value: w,
                previous: world[i - 1],
            });
        }
        out.push(t);
    }
    Ok(out)
}
