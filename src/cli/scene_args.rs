//! The options that `render` and `view` share (what to draw and how), and
//! their conversion to the library's `RenderOptions`; the default vertical
//! exaggeration is chosen and printed here.

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};

use stratasweep::gpu::render::camera::default_z_scale;
use stratasweep::gpu::render::{CellFinding, Mode, RenderOptions};
use stratasweep::grid::Grid;

use super::parse_triplet;

/// `--projection`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum ProjectionArg {
    /// Orthographic.
    Ortho,
    /// Perspective (30° field of view).
    Perspective,
}

/// `--mode`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum ModeArg {
    /// Opacity-corrected slices.
    Volume,
    /// Slices with the transfer function's opacity as is.
    Slices,
    /// Opaque lit isosurfaces.
    Iso,
}

/// `--cells`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum CellsArg {
    /// GPU binning on hardware GPUs, the CPU sweep on software rasterizers.
    Auto,
    /// The CPU's incremental sweep.
    Sweep,
    /// Span-space binning on the GPU.
    Gpu,
}

/// Options shared by `render` and `view`.
#[derive(Args, Clone, Debug)]
pub struct SceneArgs {
    /// Property to show (default: the first that is not constant, point properties before cell properties; without properties, the slice position along the axis).
    #[arg(long)]
    pub property: Option<String>,
    /// Slices along the axis most parallel to the view direction.
    #[arg(long, default_value_t = 200)]
    pub slices: usize,
    /// Direction the camera looks along.
    #[arg(long, default_value = "-1,-0.6,-0.8", allow_hyphen_values = true)]
    pub view_dir: String,
    /// Up vector (default +z, or +y when looking along z).
    #[arg(long, allow_hyphen_values = true)]
    pub up: Option<String>,
    /// Projection.
    #[arg(long, value_enum, default_value = "ortho")]
    pub projection: ProjectionArg,
    /// Colormap name (viridis, magma, coolwarm, greys; linear opacity ramp) or a JSON file
    /// `{"points":[{"value":v,"color":[r,g,b],"opacity":a},...]}`.
    #[arg(long, default_value = "viridis")]
    pub transfer: String,
    /// Distance U that the opacities are given per (default: the mean cell size).
    #[arg(long)]
    pub unit_distance: Option<f64>,
    /// Background `R,G,B,A` in [0, 1], or `transparent`.
    #[arg(long, default_value = "1,1,1,1")]
    pub background: String,
    /// Image size.
    #[arg(long, default_value = "800x600")]
    pub size: String,
    /// Volume (opacity-corrected slices), slices (opacity as is) or iso (opaque isosurfaces).
    #[arg(long, value_enum, default_value = "volume")]
    pub mode: ModeArg,
    /// Isovalues for `--mode iso`.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub iso: Vec<f64>,
    /// Vertical exaggeration: z is multiplied by S for display (default: 1 for
    /// grids at least a quarter as high as wide, else 2, 5, 10, 20, ... so that
    /// flat reservoirs are readable; the value used is printed).
    #[arg(long)]
    pub z_scale: Option<f64>,
    /// Volume mode with pre-integrated transfer functions (each slab from its
    /// front and back value): fewer slices for the same quality.
    #[arg(long)]
    pub preintegrated: bool,
    /// Adapter name (substring); `WGPU_BACKEND` picks backends.
    #[arg(long)]
    pub adapter: Option<String>,
    /// How the cut cells of the slices are found: the CPU sweep, span-space
    /// binning on the GPU, or auto (the GPU unless it is a software
    /// rasterizer such as llvmpipe). Default: auto for `view`; the sweep for
    /// `render`, whose PNG is then the same bits on every run (binning
    /// orders a level's polygons by GPU atomics, which changes the blending
    /// where polygons of one level overlap, along faults).
    #[arg(long, value_enum)]
    pub cells: Option<CellsArg>,
}

/// `--size WxH`, each side at most [`stratasweep::limits::MAX_IMAGE_SIDE`].
pub fn parse_size(s: &str) -> Result<(u32, u32)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("--size '{s}': expected WxH, e.g. 800x600"))?;
    let max = stratasweep::limits::MAX_IMAGE_SIDE;
    let side = |x: &str| {
        x.trim()
            .parse::<u64>()
            .ok()
            .filter(|&v| v >= 1 && v <= max as u64)
    };
    let (Some(w), Some(h)) = (side(w), side(h)) else {
        bail!(
            "--size '{s}': each side must be a whole number in 1..={max} (the limit of the image side)"
        );
    };
    Ok((w as u32, h as u32))
}

/// `--background R,G,B,A` or `transparent`.
pub fn parse_background(s: &str) -> Result<Option<[f32; 4]>> {
    if s.eq_ignore_ascii_case("transparent") {
        return Ok(None);
    }
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--background '{s}': expected R,G,B,A or transparent"))?;
    if v.len() != 4 || v.iter().any(|c| !(0.0..=1.0).contains(c)) {
        bail!("--background '{s}': expected four values in [0, 1] (R,G,B,A) or transparent");
    }
    Ok(Some([v[0], v[1], v[2], v[3]]))
}

impl SceneArgs {
    /// The library's options (checked before the grid is loaded).
    pub fn options(&self) -> Result<RenderOptions> {
        let view = parse_triplet(&self.view_dir, "--view-dir")?;
        let up = self
            .up
            .as_deref()
            .map(|u| parse_triplet(u, "--up"))
            .transpose()?;
        let size = parse_size(&self.size)?;
        let background = parse_background(&self.background)?;
        let (transfer, colormap) = super::render_checks::read_transfer(&self.transfer)?;
        let mode = match self.mode {
            ModeArg::Volume => Mode::Volume,
            ModeArg::Slices => Mode::Slices,
            ModeArg::Iso => Mode::Iso,
        };
        if mode == Mode::Iso && self.iso.is_empty() {
            bail!("--mode iso needs --iso VALUES (comma-separated)");
        }
        stratasweep::limits::check_isovalues(self.iso.len())
            .map_err(crate::cli::checks::flag("--iso"))?;
        if let Some(z) = self.z_scale
            && !(z.is_finite() && z > 0.0)
        {
            bail!("--z-scale {z}: must be a positive number");
        }
        Ok(RenderOptions {
            property: self.property.clone(),
            slices: self.slices,
            view_dir: view,
            up,
            perspective: self.projection == ProjectionArg::Perspective,
            transfer,
            colormap,
            unit_distance: self.unit_distance,
            background,
            size,
            mode,
            iso: self.iso.clone(),
            cells: match self.cells {
                None | Some(CellsArg::Auto) => CellFinding::Auto,
                Some(CellsArg::Sweep) => CellFinding::Sweep,
                Some(CellsArg::Gpu) => CellFinding::Gpu,
            },
        })
    }

    /// `--z-scale`, or the default for the grid's bounding box; printed
    /// unless quiet.
    pub fn z_scale(&self, grid: &Grid, quiet: bool) -> f64 {
        let (lo, hi) = grid.bounds();
        let (z, how) = match self.z_scale {
            Some(z) => (z, "--z-scale"),
            None => (default_z_scale(lo, hi), "default for this grid's extents"),
        };
        if !quiet {
            eprintln!(
                "z-scale {z} ({how}; box {:.4} x {:.4} x {:.4})",
                hi[0] - lo[0],
                hi[1] - lo[1],
                hi[2] - lo[2]
            );
        }
        z
    }
}

/// `--ijk-clip I0:I1,J0:J1,K0:K1` → cell index ranges `lo..hi` per axis;
/// every error names the option and the part that is wrong.
pub fn parse_clip(s: &str) -> Result<[[usize; 2]; 3]> {
    let form = "expected I0:I1,J0:J1,K0:K1 (cell index ranges, I0 < I1, e.g. 0:10,0:20,2:5)";
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        bail!("--ijk-clip '{s}': {} range(s) given; {form}", parts.len());
    }
    let mut out = [[0usize; 2]; 3];
    for (a, p) in parts.iter().enumerate() {
        let axis = ["I", "J", "K"][a];
        let Some((lo, hi)) = p.split_once(':') else {
            bail!("--ijk-clip '{s}': the {axis} range '{p}' has no ':'; {form}");
        };
        let num = |x: &str| {
            x.trim().parse::<usize>().map_err(|_| {
                anyhow::anyhow!(
                    "--ijk-clip '{s}': the {axis} range '{p}': '{x}' is not a cell index (a whole number from 0); {form}"
                )
            })
        };
        let (lo, hi) = (num(lo)?, num(hi)?);
        if lo >= hi {
            bail!("--ijk-clip '{s}': the {axis} range {lo}:{hi} is empty; {form}");
        }
        out[a] = [lo, hi];
    }
    Ok(out)
}

/// Refuses an `--ijk-clip` box that keeps no cell of `grid` (a blank
/// frame otherwise), naming the grid's cell ranges; a box that is not on
/// an IJK grid is refused by the renderer.
pub fn check_clip(clip: &[[usize; 2]; 3], grid: &Grid) -> Result<()> {
    let stratasweep::grid::Topology::Structured { dims } = &grid.topology else {
        return Ok(());
    };
    let cells = dims.map(|d| d.saturating_sub(1));
    if let Some(a) = (0..3).find(|&a| clip[a][0] >= cells[a]) {
        bail!(
            "--ijk-clip {}: the box lies outside the grid, whose cells are I 0:{}, J 0:{}, K 0:{} (the {} range starts at {}, past the last cell {})",
            clip.map(|r| format!("{}:{}", r[0], r[1])).join(","),
            cells[0],
            cells[1],
            cells[2],
            ["I", "J", "K"][a],
            clip[a][0],
            cells[a].saturating_sub(1)
        );
    }
    Ok(())
}
