//! `render`'s checks against blank images: the library's (a constant
//! property), isovalues outside the property's range (refused before
//! rendering), and an image in which nothing was drawn (a warning naming
//! the likely cause).

use anyhow::{Result, bail};
use stratasweep::gpu::render::{Image, Mode, RenderOptions, Transfer};
use stratasweep::gpu::shown::{check_shown_property, property_range, shown_property};
use stratasweep::grid::Grid;

/// Refuses a render that can only be blank ([`check_shown_property`]: a
/// property without a finite value, or a constant one without a transfer
/// function), and one whose isovalues all lie outside the property's
/// range. Notes a default property chosen past constant ones. Returns the
/// isovalues outside the range (each one draws nothing).
pub fn check_before(grid: &Grid, o: &RenderOptions) -> Result<Vec<f64>> {
    check_shown_property(grid, o)?;
    let Some(name) = shown_property(grid, o) else {
        return Ok(Vec::new());
    };
    let Some((lo, hi)) = property_range(grid, &name) else {
        return Ok(Vec::new()); // the renderer names the missing property
    };
    if o.property.is_none() {
        let first = grid.point_data.iter().chain(&grid.cell_data).next();
        if let Some(first) = first.filter(|p| p.name != name) {
            eprintln!(
                "note: showing '{name}', the first property that is not constant ('{}' is; --property to choose)",
                first.name
            );
        }
    }
    let iso = if o.mode == Mode::Iso { &o.iso[..] } else { &[] };
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
