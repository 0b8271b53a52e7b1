//! What a render asks for ([`RenderOptions`], [`Mode`], [`CellFinding`])
//! and what its defaults resolve to: the transfer function
//! ([`transfer_for`]) and the unit distance of the opacities
//! ([`unit_distance`], by default the [`mean_cell_size`]).

use crate::grid::Grid;

use super::error::RenderError;
use super::transfer::{COLORMAPS, Transfer};

/// How to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Slices with opacity corrected for spacing and angle.
    Volume,
    /// Slices with the transfer function's opacity as is.
    Slices,
    /// Opaque lit isosurfaces.
    Iso,
}

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Property shown (default: [`super::shown::default_property`]; without
    /// properties the slice position along the axis).
    pub property: Option<String>,
    /// Slices along the chosen axis (volume and slices modes).
    pub slices: usize,
    /// Direction the camera looks along.
    pub view_dir: [f64; 3],
    /// Up vector (default: +z, or +y when looking along z).
    pub up: Option<[f64; 3]>,
    /// Perspective (else orthographic).
    pub perspective: bool,
    /// Transfer function; `None`: viridis over the property's range.
    pub transfer: Option<Transfer>,
    /// Named colormap used when `transfer` is `None`.
    pub colormap: String,
    /// Unit distance U of the opacities (default: the mean cell size).
    pub unit_distance: Option<f64>,
    /// Background (straight RGBA); `None`: transparent.
    pub background: Option<[f32; 4]>,
    /// Image size in pixels.
    pub size: (u32, u32),
    /// Mode.
    pub mode: Mode,
    /// Isovalues (iso mode).
    pub iso: Vec<f64>,
    /// How the cut cells of the slices are found.
    pub cells: CellFinding,
}

/// How the cut cells of the slices are found before the GPU emits them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CellFinding {
    /// GPU binning on hardware GPUs, the CPU sweep on software ones
    /// (llvmpipe), where the sweep is faster.
    #[default]
    Auto,
    /// The CPU sweep (the paper's incremental sweep).
    Sweep,
    /// Span-space binning of every live cell on the GPU; the sweep still
    /// serves IJK clips, grids split into parts and frames over the
    /// device's limits.
    Gpu,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            property: None,
            slices: 200,
            view_dir: [-1.0, -0.6, -0.8],
            up: None,
            perspective: false,
            transfer: None,
            colormap: "viridis".into(),
            unit_distance: None,
            background: Some([1.0, 1.0, 1.0, 1.0]),
            size: (800, 600),
            mode: Mode::Volume,
            iso: Vec::new(),
            cells: CellFinding::Auto,
        }
    }
}

/// The transfer function of `o` for a property range: `o.transfer`, else
/// its named colormap over the range.
pub fn transfer_for(o: &RenderOptions, range: (f64, f64)) -> Result<Transfer, RenderError> {
    match &o.transfer {
        Some(t) => Ok(t.clone()),
        None => Transfer::named(&o.colormap, range.0, range.1).ok_or_else(|| {
            RenderError::Options(format!(
                "unknown colormap '{}' (known: {})",
                o.colormap,
                COLORMAPS.join(", ")
            ))
        }),
    }
}

/// The unit distance of the opacities in display space: `o.unit_distance`,
/// else the mean cell size of the exaggerated bounding box.
pub fn unit_distance(grid: &Grid, o: &RenderOptions, z_scale: f64) -> Result<f64, RenderError> {
    match o.unit_distance {
        Some(u) if u > 0.0 && u.is_finite() => Ok(u),
        Some(u) => Err(RenderError::Options(format!(
            "the unit distance {u} must be positive"
        ))),
        None => Ok(mean_cell_size(grid) * z_scale.cbrt()),
    }
}

/// Mean cell size: the cube root of the bounding-box volume per cell
/// (the default unit distance of the opacities).
pub fn mean_cell_size(grid: &Grid) -> f64 {
    let (lo, hi) = grid.bounds();
    let v: f64 = (0..3).map(|a| (hi[a] - lo[a]).max(1e-30)).product();
    (v / grid.cell_count().max(1) as f64).cbrt()
}
