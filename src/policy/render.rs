//! Render requests: the raw choices of `render`, `view` and Python's
//! `Grid.render` ([`RenderRequest`]), validated once into a
//! [`RenderPlan`] before the grid is loaded; then, on the loaded grid, the
//! vertical exaggeration ([`RenderPlan::z_scale`]), the checks against a
//! blank image and isovalues outside the data ([`RenderPlan::check_grid`])
//! and the drawing itself with the legend ([`RenderPlan::draw`]).

use crate::gpu::render::camera::{default_z_scale, slicing_axis};
use crate::gpu::render::checks::{check_modes, check_options};
use crate::gpu::render::shown::{property_range, shown_property};
use crate::gpu::render::slice_cache::slice_key;
use crate::gpu::render::{CellFinding, Image, Mode, RenderError, RenderOptions, Renderer};
use crate::grid::Grid;
use crate::limits;
use crate::structures::Structure;

use super::transfer::{ReadTransfer, TransferChoice, read};
use super::{Message, Opt, PolicyError, Value, limit};

/// What the image is for: `render`'s PNG (and Python's array) or `view`'s
/// window; the default way of finding cut cells differs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Target {
    /// One image: the CPU sweep by default, the same bits on every run
    /// (GPU binning orders a level's polygons by atomics, which changes
    /// the blending where polygons of one level overlap, along faults).
    #[default]
    Image,
    /// The interactive window: [`CellFinding::Auto`] by default.
    Window,
}

/// The background as a front end gives it.
#[derive(Clone, Debug, PartialEq)]
pub enum Background {
    /// `R,G,B,A` in [0, 1], or `transparent` (any case).
    Text(String),
    /// Values that must be four in [0, 1].
    Values(Vec<f64>),
}

/// The raw choices of one render, as the user gave them.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderRequest {
    /// Shown property (default: the first that is not constant).
    pub property: Option<String>,
    /// Slices along the axis most parallel to the view direction.
    pub slices: i128,
    /// Direction the camera looks along.
    pub view_dir: [f64; 3],
    /// Up vector (default +z, or +y when looking along z).
    pub up: Option<[f64; 3]>,
    /// Perspective projection (else orthographic).
    pub perspective: bool,
    /// Colormap name, transfer-function file or JSON.
    pub transfer: TransferChoice,
    /// Distance the opacities are given per (default: the mean cell size).
    pub unit_distance: Option<f64>,
    /// Background.
    pub background: Background,
    /// Image width and height in pixels.
    pub size: (i128, i128),
    /// Volume, slices or iso.
    pub mode: Mode,
    /// Isovalues (iso mode).
    pub iso: Vec<f64>,
    /// Vertical exaggeration (default: [`default_z_scale`]).
    pub z_scale: Option<f64>,
    /// Pre-integrated volume rendering.
    pub preintegrated: bool,
    /// How cut cells are found (default: by [`Target`]).
    pub cells: Option<CellFinding>,
    /// Draw the colour legend into the image.
    pub legend: bool,
    /// Image or window.
    pub target: Target,
}

impl Default for RenderRequest {
    fn default() -> Self {
        RenderRequest {
            property: None,
            slices: 200,
            view_dir: [-1.0, -0.6, -0.8],
            up: None,
            perspective: false,
            transfer: TransferChoice::default(),
            unit_distance: None,
            background: Background::Text("1,1,1,1".into()),
            size: (800, 600),
            mode: Mode::Volume,
            iso: Vec::new(),
            z_scale: None,
            preintegrated: false,
            cells: None,
            legend: false,
            target: Target::Image,
        }
    }
}

/// A word a front end passes for an enumerated option, checked against
/// its names: `mode 'x': expected 'volume', 'slices' or 'iso'`.
pub fn word<T: Copy>(opt: Opt, s: &str, names: &[(&str, T)]) -> Result<T, PolicyError> {
    if let Some((_, v)) = names.iter().find(|(n, _)| *n == s) {
        return Ok(*v);
    }
    let quoted: Vec<String> = names.iter().map(|(n, _)| format!("'{n}'")).collect();
    let list = match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    };
    Err(PolicyError::invalid(
        Message::new()
            .opt(opt)
            .text(format!(" '{s}': expected {list}")),
    ))
}

/// The names of the modes.
pub const MODES: [(&str, Mode); 3] = [
    ("volume", Mode::Volume),
    ("slices", Mode::Slices),
    ("iso", Mode::Iso),
];

/// The names of the projections (`true`: perspective).
pub const PROJECTIONS: [(&str, bool); 2] = [("ortho", false), ("perspective", true)];

/// The names of the ways of finding cut cells.
pub const CELLS: [(&str, CellFinding); 3] = [
    ("auto", CellFinding::Auto),
    ("sweep", CellFinding::Sweep),
    ("gpu", CellFinding::Gpu),
];

/// A render request validated: the renderer's options and what the
/// front end does around them.
#[derive(Clone, Debug)]
pub struct RenderPlan {
    /// The renderer's options.
    pub options: RenderOptions,
    /// The vertical exaggeration asked for (`None`: the grid's default).
    pub z_scale: Option<f64>,
    /// Pre-integrated volume rendering.
    pub preintegrated: bool,
    /// Draw the colour legend.
    pub legend: bool,
    /// The transfer function as named (for messages).
    pub transfer: TransferChoice,
}

/// The largest image side (see [`limits::MAX_IMAGE_SIDE`]).
fn side(n: i128) -> Result<u32, PolicyError> {
    let max = limits::MAX_IMAGE_SIDE;
    match limits::check_image_side(n) {
        Ok(v) => Ok(v),
        Err(_) => Err(PolicyError::invalid(Message::new().opt(Opt::Size).text(
            format!(
                " {n} is outside 1..={max}: each side must be a whole number in 1..={max} (the limit of the image side)"
            ),
        ))),
    }
}

/// The background: `None` for transparent.
pub fn background(b: &Background) -> Result<Option<[f32; 4]>, PolicyError> {
    let bad = |shown: String, what: &str| {
        PolicyError::invalid(
            Message::new()
                .opt(Opt::Background)
                .text(format!(" {shown}: expected {what}")),
        )
    };
    let four = "four values in [0, 1] (R,G,B,A) or transparent";
    let v: Vec<f32> = match b {
        Background::Text(s) if s.eq_ignore_ascii_case("transparent") => return Ok(None),
        Background::Text(s) => s
            .split(',')
            .map(|x| x.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad(format!("'{s}'"), "R,G,B,A or transparent"))?,
        Background::Values(v) => v.iter().map(|&x| x as f32).collect(),
    };
    if v.len() != 4 || v.iter().any(|c| !(0.0..=1.0).contains(c)) {
        let shown = match b {
            Background::Text(s) => format!("'{s}'"),
            Background::Values(v) => format!("{v:?}"),
        };
        return Err(bad(shown, four));
    }
    Ok(Some([v[0], v[1], v[2], v[3]]))
}

impl RenderRequest {
    /// Validates the request (before the grid is loaded): the library's
    /// limits, the image size, background, transfer function, mode and
    /// isovalues, vertical exaggeration, and options the mode ignores.
    pub fn resolve(&self) -> Result<RenderPlan, PolicyError> {
        let slices = limits::check_slices(self.slices).map_err(limit(Opt::Slices))?;
        let size = (side(self.size.0)?, side(self.size.1)?);
        let background = background(&self.background)?;
        let ReadTransfer { transfer, colormap } = read(&self.transfer)?;
        if self.mode == Mode::Iso && self.iso.is_empty() {
            return Err(PolicyError::invalid(
                Message::new()
                    .opt_is(Opt::Mode, Value::Word("iso"))
                    .text(" needs ")
                    .opt(Opt::Iso)
                    .text(" values"),
            ));
        }
        limits::check_isovalues(self.iso.len()).map_err(limit(Opt::Iso))?;
        if let Some(z) = self.z_scale
            && !(z.is_finite() && z > 0.0)
        {
            return Err(PolicyError::invalid(
                Message::new()
                    .opt(Opt::ZScale)
                    .text(format!(" {z}: must be a positive number")),
            ));
        }
        let options = RenderOptions {
            property: self.property.clone(),
            slices,
            view_dir: self.view_dir,
            up: self.up,
            perspective: self.perspective,
            transfer,
            colormap,
            unit_distance: self.unit_distance,
            background,
            size,
            mode: self.mode,
            iso: self.iso.clone(),
            cells: self.cells.unwrap_or(match self.target {
                Target::Image => CellFinding::Sweep,
                Target::Window => CellFinding::Auto,
            }),
        };
        // A window's panel switches modes: its isovalues and pre-integration
        // wait for the mode that uses them; an image would ignore them.
        let checked = match self.target {
            Target::Image => check_modes(&options, self.preintegrated),
            Target::Window => Ok(()),
        };
        checked.map_err(|e| {
            PolicyError::from(e).context(
                Message::new()
                    .opt(Opt::Mode)
                    .text(", ")
                    .opt(Opt::Iso)
                    .text(" and ")
                    .opt(Opt::Preintegrated),
            )
        })?;
        Ok(RenderPlan {
            options,
            z_scale: self.z_scale,
            preintegrated: self.preintegrated,
            legend: self.legend,
            transfer: self.transfer.clone(),
        })
    }
}

/// The vertical exaggeration of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZScale {
    /// z is multiplied by this for display.
    pub value: f64,
    /// Whether the request gave it (else the grid's default).
    pub given: bool,
}

/// Whether a notice is a warning or a note.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// Something the user should look at (the image may not show what
    /// they meant).
    Warning,
    /// A choice made for the user.
    Note,
}

/// A warning or note about a render that goes ahead.
#[derive(Clone, Debug, PartialEq)]
pub struct Notice {
    /// Warning or note.
    pub level: Level,
    /// The text.
    pub text: Message,
}

/// What [`RenderPlan::draw`] drew.
pub struct Drawn {
    /// The image (with the legend when asked for).
    pub image: Image,
    /// Compute dispatches of the renderer so far.
    pub dispatches: u64,
    /// Pre-integrated volume frame that did not march the property in
    /// index space: why.
    pub fallback: Option<String>,
    /// Every pixel is the background: nothing was drawn.
    pub blank: bool,
}

impl RenderPlan {
    /// The vertical exaggeration: as asked, else 1 for grids at least a
    /// quarter as high as wide, else 2, 5, 10, 20, ... so that flat
    /// reservoirs are readable ([`default_z_scale`]).
    pub fn z_scale(&self, grid: &Grid) -> ZScale {
        match self.z_scale {
            Some(value) => ZScale { value, given: true },
            None => ZScale {
                value: grid_z_scale(grid),
                given: false,
            },
        }
    }

    /// The context of the transfer function's messages.
    fn transfer_context(&self) -> Message {
        match (&self.options.transfer, &self.transfer) {
            (None, _) => Message::new().text("render options"),
            (Some(_), TransferChoice::Named(s)) => {
                Message::new().opt(Opt::Transfer).text(format!(" {s}"))
            }
            (Some(_), TransferChoice::Json(_)) => Message::new().opt(Opt::Transfer),
        }
    }

    /// On the loaded grid: refuses a render that can only be blank (the
    /// renderer's [`check_options`]) and one whose isovalues all lie
    /// outside the shown property's range. Returns the renderer's
    /// warnings, a note on a default property chosen past constant ones,
    /// and a warning per isovalue outside the range (each draws nothing).
    pub fn check_grid(&self, grid: &Grid) -> Result<Vec<Notice>, PolicyError> {
        let o = &self.options;
        let what = self.transfer_context();
        let warnings = check_options(grid, o, self.preintegrated)
            .map_err(|e| PolicyError::from(e).context(what.clone()))?;
        let mut out: Vec<Notice> = warnings
            .into_iter()
            .map(|w| Notice {
                level: Level::Warning,
                text: what.clone().text(format!(": {w}")),
            })
            .collect();
        let Some(name) = shown_property(grid, o) else {
            return Ok(out);
        };
        let Some((lo, hi)) = property_range(grid, &name) else {
            return Ok(out); // the renderer names the missing property
        };
        if o.property.is_none() {
            let first = grid.point_data.iter().chain(&grid.cell_data).next();
            if let Some(first) = first.filter(|p| p.name != name) {
                out.push(Notice {
                    level: Level::Note,
                    text: Message::new()
                        .text(format!(
                            "showing '{name}', the first property that is not constant ('{}' is; ",
                            first.name
                        ))
                        .opt(Opt::Property)
                        .text(" to choose)"),
                });
            }
        }
        let iso = if o.mode == Mode::Iso { &o.iso[..] } else { &[] };
        let outside: Vec<f64> = iso
            .iter()
            .copied()
            .filter(|v| !(lo < *v && *v <= hi))
            .collect();
        if !iso.is_empty() && outside.len() == iso.len() {
            let list: Vec<String> = iso.iter().map(f64::to_string).collect();
            return Err(PolicyError::invalid(Message::new().opt(Opt::Iso).text(format!(
                " {}: every isovalue is outside the range of '{name}' ({lo} .. {hi}], so no surface would be drawn",
                list.join(",")
            ))));
        }
        for v in outside {
            out.push(Notice {
                level: Level::Warning,
                text: Message::new().opt(Opt::Iso).text(format!(
                    " {v} is outside the property's range: it draws nothing"
                )),
            });
        }
        Ok(out)
    }

    /// Draws the plan with `r` on `grid` (its structure `s`) at `z_scale`,
    /// with the legend when asked for.
    pub fn draw(
        &self,
        r: &mut Renderer,
        grid: &Grid,
        s: &Structure,
        z_scale: f64,
    ) -> Result<Drawn, RenderError> {
        let o = &self.options;
        r.set_preintegrated(self.preintegrated);
        let img = r.render_exaggerated(grid, s, o, z_scale)?;
        let image = match self.legend {
            true => crate::gpu::render::legend::legend_onto(r, grid, o, img)?,
            false => img,
        };
        Ok(Drawn {
            blank: is_blank(&image),
            image,
            dispatches: r.dispatches(),
            fallback: pre_fallback(r, grid, o),
        })
    }
}

/// The default vertical exaggeration of `grid`: 1 for grids at least a
/// quarter as high as wide, else 2, 5, 10, 20, ... ([`default_z_scale`]).
pub fn grid_z_scale(grid: &Grid) -> f64 {
    let (lo, hi) = grid.bounds();
    default_z_scale(lo, hi)
}

/// The warning for an image in which nothing was drawn (`image` names it).
pub fn blank_warning(image: &str) -> Message {
    Message::new()
        .text(format!(
            "nothing was drawn: every pixel of {image} is the background (check "
        ))
        .opt(Opt::Property)
        .text(", ")
        .opt(Opt::Transfer)
        .text(", ")
        .opt(Opt::Iso)
        .text(" and ")
        .opt(Opt::ViewDir)
        .text(")")
}

/// Why a pre-integrated volume frame did not march the property in index
/// space (the slices' reason), if it did not.
fn pre_fallback(r: &Renderer, grid: &Grid, o: &RenderOptions) -> Option<String> {
    if !r.preintegrated() || o.mode != Mode::Volume {
        return None;
    }
    let d = glam::Vec3::from_array(o.view_dir.map(|c| c as f32)).normalize();
    let k = slice_key(grid, o, slicing_axis(d))
        .ok()?
        .with_attr_gradient();
    r.slices(&k.key)?.field_fallback.clone()
}

/// True when every pixel of `img` is the same colour (the background):
/// nothing was drawn.
pub fn is_blank(img: &Image) -> bool {
    let Some(first) = img.premultiplied.first() else {
        return true;
    };
    img.premultiplied.iter().all(|p| p == first)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_resolve_to_the_renderers_defaults() {
        let p = RenderRequest::default().resolve().unwrap();
        let d = RenderOptions::default();
        assert_eq!(p.options.size, d.size);
        assert_eq!(p.options.background, d.background);
        assert_eq!(p.options.colormap, d.colormap);
        assert_eq!(p.options.slices, d.slices);
        // An image is the same bits on every run; a window finds cells
        // the fast way.
        assert_eq!(p.options.cells, CellFinding::Sweep);
        let w = RenderRequest {
            target: Target::Window,
            ..Default::default()
        };
        assert_eq!(w.resolve().unwrap().options.cells, CellFinding::Auto);
    }

    fn refusal(r: RenderRequest) -> String {
        r.resolve().unwrap_err().to_string()
    }

    #[test]
    fn bad_requests_are_refused_in_neutral_words() {
        let e = refusal(RenderRequest {
            size: (100_000, 10),
            ..Default::default()
        });
        assert!(e.starts_with("size 100000 is outside 1..=8192"), "{e}");
        let e = refusal(RenderRequest {
            background: Background::Text("1,2".into()),
            ..Default::default()
        });
        assert_eq!(
            e,
            "background '1,2': expected four values in [0, 1] (R,G,B,A) or transparent"
        );
        let e = refusal(RenderRequest {
            mode: Mode::Iso,
            ..Default::default()
        });
        assert_eq!(e, "mode='iso' needs iso values");
        let e = refusal(RenderRequest {
            iso: vec![0.5],
            ..Default::default()
        });
        assert!(
            e.starts_with("mode, iso and preintegrated: isovalues are drawn only in iso mode"),
            "{e}"
        );
        let e = refusal(RenderRequest {
            z_scale: Some(0.0),
            ..Default::default()
        });
        assert_eq!(e, "z_scale 0: must be a positive number");
        let e = refusal(RenderRequest {
            slices: 0,
            ..Default::default()
        });
        assert_eq!(e, "slices must be at least 1 (got 0)");
        assert!(
            word(Opt::Mode, "x", &MODES).unwrap_err().to_string()
                == "mode 'x': expected 'volume', 'slices' or 'iso'"
        );
        assert!(
            background(&Background::Text("transparent".into()))
                .unwrap()
                .is_none()
        );
    }

    #[test]
    fn isovalues_all_outside_the_data_are_refused_and_some_warned_about() {
        let g = crate::generate::warped([4, 4, 4], 1);
        let plan = |iso: Vec<f64>| {
            RenderRequest {
                mode: Mode::Iso,
                iso,
                ..Default::default()
            }
            .resolve()
            .unwrap()
        };
        let e = plan(vec![5.0, -5.0])
            .check_grid(&g)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("iso 5,-5: every isovalue is outside the range of 'f'"),
            "{e}"
        );
        let n = plan(vec![0.5, 5.0]).check_grid(&g).unwrap();
        assert!(
            n.iter()
                .any(|n| n.level == Level::Warning && n.text.to_string().starts_with("iso 5 ")),
            "{n:?}"
        );
    }

    #[test]
    fn the_default_z_scale_exaggerates_flat_grids() {
        let plan = RenderRequest::default().resolve().unwrap();
        let flat = crate::generate::warped([8, 8, 1], 1);
        let (lo, hi) = flat.bounds();
        let z = plan.z_scale(&flat);
        assert!(!z.given && z.value == default_z_scale(lo, hi));
        let given = RenderRequest {
            z_scale: Some(3.0),
            ..Default::default()
        };
        let z = given.resolve().unwrap().z_scale(&flat);
        assert!(z.given && z.value == 3.0);
    }
}
