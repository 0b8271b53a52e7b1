//! The options that `render` and `view` share (what to draw and how),
//! parsed into the library's [`RenderRequest`]; the policy
//! ([`stratasweep::policy::render`]) makes every choice, and the default
//! vertical exaggeration it picks is printed here.

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};

use stratasweep::gpu::render::{CellFinding, Mode};
use stratasweep::grid::Grid;
use stratasweep::policy::render::{Background, RenderPlan, RenderRequest, Target, ZScale};
use stratasweep::policy::transfer::TransferChoice;

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

/// `--size WxH`: the two sides as numbers (their range is the policy's).
pub fn parse_size(s: &str) -> Result<(i128, i128)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("--size '{s}': expected WxH, e.g. 800x600"))?;
    let max = stratasweep::limits::MAX_IMAGE_SIDE;
    let side = |x: &str| x.trim().parse::<i128>().ok();
    let (Some(w), Some(h)) = (side(w), side(h)) else {
        bail!(
            "--size '{s}': each side must be a whole number in 1..={max} (the limit of the image side)"
        );
    };
    Ok((w, h))
}

impl SceneArgs {
    /// The request these flags make (their syntax checked here, every
    /// choice in [`RenderRequest::resolve`]).
    pub fn request(&self, target: Target, legend: bool) -> Result<RenderRequest> {
        let view_dir = parse_triplet(&self.view_dir, "--view-dir")?;
        let up = self
            .up
            .as_deref()
            .map(|u| parse_triplet(u, "--up"))
            .transpose()?;
        Ok(RenderRequest {
            property: self.property.clone(),
            slices: self.slices as i128,
            view_dir,
            up,
            perspective: self.projection == ProjectionArg::Perspective,
            transfer: TransferChoice::Named(self.transfer.clone()),
            unit_distance: self.unit_distance,
            background: Background::Text(self.background.clone()),
            size: parse_size(&self.size)?,
            mode: match self.mode {
                ModeArg::Volume => Mode::Volume,
                ModeArg::Slices => Mode::Slices,
                ModeArg::Iso => Mode::Iso,
            },
            iso: self.iso.clone(),
            z_scale: self.z_scale,
            preintegrated: self.preintegrated,
            cells: self.cells.map(|c| match c {
                CellsArg::Auto => CellFinding::Auto,
                CellsArg::Sweep => CellFinding::Sweep,
                CellsArg::Gpu => CellFinding::Gpu,
            }),
            legend,
            target,
        })
    }

    /// The validated plan of these flags.
    pub fn plan(&self, target: Target, legend: bool) -> Result<RenderPlan> {
        self.request(target, legend)?
            .resolve()
            .map_err(super::checks::policy_error)
    }
}

/// Prints the vertical exaggeration `z` of `grid` unless quiet; returns it.
pub fn print_z_scale(z: ZScale, grid: &Grid, quiet: bool) -> f64 {
    let (lo, hi) = grid.bounds();
    let how = match z.given {
        true => "--z-scale",
        false => "default for this grid's extents",
    };
    if !quiet {
        eprintln!(
            "z-scale {} ({how}; box {:.4} x {:.4} x {:.4})",
            z.value,
            hi[0] - lo[0],
            hi[1] - lo[1],
            hi[2] - lo[2]
        );
    }
    z.value
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
