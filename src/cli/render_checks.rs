//! `render`'s checks against blank images: a constant property, isovalues
//! outside the property's range (refused before rendering), and an image in
//! which nothing was drawn (a warning naming the likely cause).

use anyhow::{Result, bail};
use stratasweep::gpu::render::{Image, Transfer, default_property};
use stratasweep::grid::Grid;

/// The property `render` shows and its finite range: `--property`, else
/// the renderer's [`default_property`].
fn shown_property(grid: &Grid, name: Option<&str>) -> Option<(String, (f64, f64))> {
    let name = name
        .map(str::to_string)
        .or_else(|| default_property(grid))?;
    let p = grid
        .point_property(&name)
        .or_else(|| grid.cell_property(&name))?;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..p.len() {
        let v = p.scalar_at(i);
        if v.is_finite() {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    Some((name, (lo, hi)))
}

/// Refuses a render that can only be blank: a constant (or all-NaN)
/// property, or isovalues that all lie outside the property's range.
/// Returns the isovalues outside the range (each one draws nothing).
pub fn check_before(grid: &Grid, property: Option<&str>, iso: &[f64]) -> Result<Vec<f64>> {
    let Some((name, (lo, hi))) = shown_property(grid, property) else {
        return Ok(Vec::new()); // the renderer names the missing property
    };
    if property.is_none() {
        let first = grid.point_data.iter().chain(&grid.cell_data).next();
        if let Some(first) = first.filter(|p| p.name != name) {
            eprintln!(
                "note: showing '{name}', the first property that is not constant ('{}' is; --property to choose)",
                first.name
            );
        }
    }
    if lo > hi {
        bail!("property '{name}' has no finite value: nothing to draw");
    }
    if lo == hi {
        bail!(
            "property '{name}' is constant ({lo}) over the grid: nothing to map to colours or contour (slice refuses it too)"
        );
    }
    let outside: Vec<f64> = iso
        .iter()
        .copied()
        .filter(|v| !(lo < *v && *v <= hi))
        .collect();
    if !iso.is_empty() && outside.len() == iso.len() {
        bail!(
            "--iso {}: every isovalue is outside the range of '{name}' ({lo} .. {hi}], so no surface would be drawn",
            iso.iter().map(f64::to_string).collect::<Vec<_>>().join(",")
        );
    }
    Ok(outside)
}

/// True when every pixel of `img` is the same colour (the background):
/// nothing was drawn.
pub fn is_blank(img: &Image) -> bool {
    let Some(first) = img.premultiplied.first() else {
        return true;
    };
    img.premultiplied.iter().all(|p| p == first)
}

/// Refuses a transfer function that can only draw nothing: no points, or
/// every point fully transparent. (The library renders such a function as
/// the bare background; on the command line it is a mistake.)
pub fn check_transfer(t: &Transfer) -> Result<()> {
    if t.points.is_empty() {
        bail!("the transfer function has no points: nothing would be drawn");
    }
    if t.points.iter().all(|p| p.opacity == 0.0) {
        bail!("every transfer point has opacity 0: nothing would be drawn");
    }
    Ok(())
}
