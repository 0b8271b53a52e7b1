//! The viewer's isosurfaces cached one isovalue at a time: changing one of
//! several isovalues sweeps and emits that level only; the others stay on
//! the GPU. Each level is its own [`SliceSet`] (built by [`build_slices`]
//! with that single value); a frame draws the wanted levels' sets in one
//! depth-tested pass ([`super::Renderer::encode_sets`]).

use crate::grid::Grid;
use crate::pipeline::LevelSpec;
use crate::structures::Structure;

use crate::gpu::context::GpuContext;

use super::error::RenderError;
use super::host_slices::build_slices;
use super::slice_cache::{SliceKey, SliceSet};

/// Per-isovalue surfaces of one property.
#[derive(Default)]
pub struct IsoLevels {
    property: Option<String>,
    levels: Vec<(f64, SliceSet<'static>)>,
    /// Compute dispatches of dropped levels.
    evicted_dispatches: u64,
}

/// The isovalues of an iso key (sorted, deduplicated by `slice_key`).
pub fn iso_values(k: &SliceKey) -> &[f64] {
    match &k.levels {
        LevelSpec::Values(v) if k.iso => v,
        _ => &[],
    }
}

impl IsoLevels {
    /// The values of `k` without a cached surface.
    pub fn missing(&self, k: &SliceKey) -> Vec<f64> {
        let same = self.property == k.property;
        iso_values(k)
            .iter()
            .copied()
            .filter(|v| !same || !self.levels.iter().any(|(w, _)| w == v))
            .collect()
    }

    /// Adds built levels for `k`'s property and drops every level that `k`
    /// does not want.
    pub fn insert(&mut self, k: &SliceKey, built: Vec<(f64, SliceSet<'static>)>) {
        if self.property != k.property {
            self.evict(|_| true);
            self.property = k.property.clone();
        }
        self.levels.extend(built);
        let want = iso_values(k);
        self.evict(|v| !want.contains(&v));
        self.levels.sort_by(|a, b| a.0.total_cmp(&b.0));
    }

    fn evict(&mut self, drop: impl Fn(f64) -> bool) {
        let (gone, keep): (Vec<_>, Vec<_>) = self.levels.drain(..).partition(|(v, _)| drop(*v));
        self.evicted_dispatches += gone.iter().map(|(_, s)| s.dispatches()).sum::<u64>();
        self.levels = keep;
    }

    /// The cached surfaces of every value of `k`, or `None` if one is missing.
    pub fn sets(&self, k: &SliceKey) -> Option<Vec<&SliceSet<'static>>> {
        if self.property != k.property {
            return None;
        }
        iso_values(k)
            .iter()
            .map(|v| self.levels.iter().find(|(w, _)| w == v).map(|(_, s)| s))
            .collect()
    }

    /// Compute dispatches issued for these levels (dropped ones included).
    pub fn dispatches(&self) -> u64 {
        self.evicted_dispatches + self.levels.iter().map(|(_, s)| s.dispatches()).sum::<u64>()
    }
}

/// Builds the surfaces of `values` for iso key `k`, one level each (runs
/// on the viewer's worker).
pub fn build_levels(
    ctx: &'static GpuContext,
    grid: &Grid,
    s: &Structure,
    k: &SliceKey,
    values: &[f64],
) -> Result<Vec<(f64, SliceSet<'static>)>, RenderError> {
    values
        .iter()
        .map(|&v| {
            let mut one = k.clone();
            one.levels = LevelSpec::Values(vec![v]);
            Ok((v, build_slices(ctx, grid, s, &one)?))
        })
        .collect()
}
