//! `render`'s checks against blank images and ignored options: the
//! library's ([`check_options`]: a constant property, a transfer function
//! that draws nothing or lies outside the data, isovalues or
//! pre-integration the mode ignores), isovalues outside the property's
//! range (refused when all are), an image in which nothing was drawn (a
//! warning naming the likely cause), and `--transfer` read as a colormap
//! name or a JSON file.

use anyhow::{Context, Result, bail};
use stratasweep::gpu::render::checks::{check_modes, check_options};
use stratasweep::gpu::render::shown::{property_range, shown_property};
use stratasweep::gpu::render::{Image, Mode, RenderOptions, Transfer, TransferSource};
use stratasweep::grid::Grid;

use super::scene_args::SceneArgs;

/// `--transfer`: a colormap name (the transfer function is then `None`) or
/// a JSON file, read and parsed; anything else refused naming both.
pub fn read_transfer(arg: &str) -> Result<(Option<Transfer>, String)> {
    let path = match TransferSource::parse(arg) {
        Ok(TransferSource::Colormap(name)) => return Ok((None, name)),
        Ok(TransferSource::File(path)) => path,
        Err(e) => {
            let exists = std::path::Path::new(arg).is_file();
            let hint = if exists {
                " (a file of that name exists: a transfer-function file must be named *.json)"
            } else {
                ""
            };
            bail!("--transfer: {e}{hint}");
        }
    };
    let bytes = std::fs::read(&path)
        .with_context(|| format!("cannot read the transfer function {path}"))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!(
            "{path} is not UTF-8 text (byte {})",
            e.utf8_error().valid_up_to()
        )
    })?;
    let t = Transfer::from_json(&text).with_context(|| format!("in {path}"))?;
    Ok((Some(t), String::new()))
}

/// Refuses options that a mode ignores (`--iso` outside iso mode,
/// `--preintegrated` outside volume mode), before the grid is loaded.
pub fn check_mode_flags(o: &RenderOptions, scene: &SceneArgs) -> Result<()> {
    check_modes(o, scene.preintegrated).context("--mode, --iso and --preintegrated")?;
    Ok(())
}

/// Refuses a render that can only be blank (the library's
/// [`check_options`]) and one whose isovalues all lie outside the
/// property's range; prints the library's warnings, a note on a default
/// property chosen past constant ones, and one warning per isovalue
/// outside the range (each draws nothing).
pub fn check_before(grid: &Grid, o: &RenderOptions, scene: &SceneArgs) -> Result<()> {
    let what = match &o.transfer {
        Some(_) => format!("--transfer {}", scene.transfer),
        None => "render options".into(),
    };
    for w in check_options(grid, o, scene.preintegrated).context(what.clone())? {
        eprintln!("warning: {what}: {w}");
    }
    let Some(name) = shown_property(grid, o) else {
        return Ok(());
    };
    let Some((lo, hi)) = property_range(grid, &name) else {
        return Ok(()); // the renderer names the missing property
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
    for v in outside {
        eprintln!("warning: --iso {v} is outside the property's range: it draws nothing");
    }
    Ok(())
}

/// True when every pixel of `img` is the same colour (the background):
/// nothing was drawn.
pub fn is_blank(img: &Image) -> bool {
    let Some(first) = img.premultiplied.first() else {
        return true;
    };
    img.premultiplied.iter().all(|p| p == first)
}
