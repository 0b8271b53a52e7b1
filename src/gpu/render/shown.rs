//! What a render shows: the property (named, or the first that varies)
//! and the checks that refuse a render that could only be blank.

use crate::grid::{Grid, Property};

use super::error::RenderError;
use super::options::{Mode, RenderOptions};

/// The property shown by `o` on `grid`: the named one, else
/// [`default_property`].
pub fn shown_property(grid: &Grid, o: &RenderOptions) -> Option<String> {
    match &o.property {
        // The grid's own spelling (names match regardless of case), so the
        // legend and the cache key read `PORO` for `--property poro`.
        Some(n) => Some(
            grid.point_property(n)
                .or_else(|| grid.cell_property(n))
                .map_or_else(|| n.clone(), |p| p.name.clone()),
        ),
        None => default_property(grid),
    }
}

/// The property shown when none is named: the first point property, else
/// the first cell property, that takes two different finite values (a
/// constant one draws every slice in one colour: SPE10's PORO is 0.2
/// everywhere); when every property is constant, the first of them; none
/// without properties (the slices then show their position).
pub fn default_property(grid: &Grid) -> Option<String> {
    let all = || grid.point_data.iter().chain(&grid.cell_data);
    all()
        .find(|p| {
            let (lo, hi) = finite_range(p);
            lo < hi
        })
        .or_else(|| all().next())
        .map(|p| p.name.clone())
}

/// The finite value range of property `name` on `grid` (point property,
/// else cell property): `lo > hi` when it has no finite value; `None`
/// when the grid has no property of that name.
pub fn property_range(grid: &Grid, name: &str) -> Option<(f64, f64)> {
    let p = grid
        .point_property(name)
        .or_else(|| grid.cell_property(name))?;
    Some(finite_range(p))
}

/// Refuses options that can only give a blank image: a shown property
/// without a finite value, or a constant one that is contoured (no level
/// lies inside its range) or coloured by a colormap (which spans the
/// range; a transfer function's own points still colour it).
pub fn check_shown_property(grid: &Grid, o: &RenderOptions) -> Result<(), RenderError> {
    let Some(name) = shown_property(grid, o) else {
        return Ok(());
    };
    let Some((lo, hi)) = property_range(grid, &name) else {
        return Ok(()); // the slicing names the missing property
    };
    if lo > hi {
        return Err(RenderError::Options(format!(
            "property '{name}' has no finite value: nothing to draw"
        )));
    }
    if lo == hi && (o.mode == Mode::Iso || o.transfer.is_none()) {
        return Err(RenderError::Options(format!(
            "property '{name}' is constant ({lo}) over the grid: nothing to map to colours or contour (slice refuses it too)"
        )));
    }
    Ok(())
}

/// The smallest and largest finite value of `p` (`lo > hi` without one).
fn finite_range(p: &Property) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..p.len() {
        let v = p.scalar_at(i);
        if v.is_finite() {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    (lo, hi)
}
