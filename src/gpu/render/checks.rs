//! The checks of a render's options before it runs, shared by every front
//! end: the shown property, options the mode would ignore, and a transfer
//! function that can only draw nothing.

use glam::Vec3;

use crate::grid::Grid;

use super::camera::slicing_axis;
use super::error::RenderError;
use super::options::{Mode, RenderOptions, transfer_for};
use super::shown::{check_shown_property, property_range, shown_property};

/// The checks of `o` before a render, shared by every front end: the shown
/// property ([`check_shown_property`]), options the mode does not use
/// ([`check_modes`]) and the transfer function ([`check_transfer`]).
/// Returns the warnings to show.
pub fn check_options(
    grid: &Grid,
    o: &RenderOptions,
    preintegrated: bool,
) -> Result<Vec<String>, RenderError> {
    check_shown_property(grid, o)?;
    check_modes(o, preintegrated)?;
    check_transfer(grid, o)
}

/// Refuses options that the mode would silently ignore: isovalues outside
/// iso mode, pre-integration outside volume mode.
pub fn check_modes(o: &RenderOptions, preintegrated: bool) -> Result<(), RenderError> {
    let mode = format!("{:?}", o.mode).to_lowercase();
    if o.mode != Mode::Iso && !o.iso.is_empty() {
        return Err(RenderError::Options(format!(
            "isovalues are drawn only in iso mode, and the mode is {mode}: choose iso mode or leave the isovalues out"
        )));
    }
    if preintegrated && o.mode != Mode::Volume {
        return Err(RenderError::Options(format!(
            "pre-integration applies only to volume mode, and the mode is {mode}: choose volume mode or leave pre-integration off"
        )));
    }
    Ok(())
}

/// Refuses a transfer function that can only draw nothing (no points;
/// every point, or every point over the shown values' range, transparent
/// outside iso mode) and an unknown colormap; warns when the transfer
/// function lies wholly outside the shown values (see
/// [`Transfer::check`](super::transfer::Transfer::check)). Returns the warnings.
pub fn check_transfer(grid: &Grid, o: &RenderOptions) -> Result<Vec<String>, RenderError> {
    let Some(t) = &o.transfer else {
        transfer_for(o, (0.0, 1.0))?;
        return Ok(Vec::new());
    };
    let property = shown_property(grid, o);
    let data = match &property {
        Some(name) => property_range(grid, name).map(|r| (r, format!("property '{name}'"))),
        None => {
            let d = Vec3::from_array(o.view_dir.map(|c| c as f32));
            let axis = slicing_axis(d);
            let (lo, hi) = grid.bounds();
            Some((
                (lo[axis], hi[axis]),
                format!("the slice positions along {}", ["x", "y", "z"][axis]),
            ))
        }
    };
    let data = data.as_ref().map(|(r, what)| (*r, what.as_str()));
    Ok(t.check(o.mode == Mode::Iso, data)?)
}
