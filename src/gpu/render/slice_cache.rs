//! The slices a render draws and their cache key.
//!
//! The slices of one (axis, slice count, property) stay on the GPU as a
//! [`SliceSet`]: another view in the same axis cone re-renders without any
//! compute dispatch. [`SliceKey`] says what to build and [`SliceId`] is its
//! typed cache key; [`GridStamp`] tells whether the cached slices were
//! built from the grid being drawn.

use crate::field::FieldSpec;
use crate::gpu::compute::emit::GpuEmitter;
use crate::grid::Grid;
use crate::pipeline::LevelSpec;
use crate::structures::Structure;

use super::error::RenderError;
use super::options::{CellFinding, Mode, RenderOptions};
use super::preintegrated::boundary::IjkBox;
use super::preintegrated::ijk_field::IjkField;
use super::preintegrated::pass::BoundaryMesh;
use super::shown::shown_property;

/// The cache key of one [`SliceSet`]: what its triangles are, whatever the
/// view inside the axis's cone.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SliceId {
    /// Slices along an axis, or isosurfaces.
    pub levels: SliceLevels,
    /// The shown property.
    pub property: Option<String>,
    /// The attribute's gradient rides along as normals (pre-integration).
    pub gradient: bool,
    /// The IJK clipping box, if any.
    pub clip: Option<IjkBox>,
}

/// The levels of a [`SliceId`].
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum SliceLevels {
    /// Evenly spaced slices along an axis (volume and slices modes).
    Axis {
        /// The slicing axis.
        axis: usize,
        /// The slice count.
        count: usize,
    },
    /// Isosurfaces at these values, sorted and deduplicated (their bits:
    /// `f64` is not `Eq`).
    Iso(Vec<u64>),
}

/// Triangles of one (axis or iso, count, property) on the GPU: the cached
/// slices that every view in the axis's cone draws without a dispatch.
pub struct SliceSet<'c> {
    /// Level chunks (one unless the frame exceeded a storage binding), in level order.
    pub(in crate::gpu::render) chunks: Vec<GpuEmitter<'c>>,
    /// Slice spacing along the axis (volume), 0 for iso.
    pub spacing: f64,
    /// Range of the shown values.
    pub range: (f64, f64),
    /// Cut cells of all levels (the frame's entries).
    pub cut_cells: u64,
    /// Levels (slices or isovalues).
    pub levels: u32,
    /// The grid's outer surface (structured grids; pre-integrated mode).
    pub boundary: Option<BoundaryMesh>,
    /// Pre-integrated mode on an IJK grid: the shown property in index
    /// space (the slices then carry `(i, j, k)` in place of the gradient).
    pub field: Option<IjkField>,
    /// Pre-integrated mode without [`Self::field`]: why (the slabs then
    /// follow the gradient path, or plain slices for a cell property).
    pub field_fallback: Option<String>,
}

impl SliceSet<'_> {
    /// Compute dispatches issued to build these slices.
    pub fn dispatches(&self) -> u64 {
        self.chunks.iter().map(|e| e.dispatches).sum()
    }
}

/// What one [`SliceSet`] is: the cache key and the request that builds it.
#[derive(Clone, Debug)]
pub struct SliceKey {
    /// Cache key (axis and count or isovalues, property, gradient, clip).
    pub key: SliceId,
    /// The field sliced: an axis, or the property (iso).
    pub field: FieldSpec,
    /// Levels.
    pub levels: LevelSpec,
    /// The shown property.
    pub property: Option<String>,
    /// Iso mode (gradients uploaded, no flat cell colour).
    pub iso: bool,
    /// Slicing axis (volume and slices modes).
    pub axis: usize,
    /// The attribute's gradient rides along as normals (pre-integration).
    pub attr_gradient: bool,
    /// IJK clipping: only cells with `lo ≤ i < hi` (and j, k) are drawn
    /// (IJK grids).
    pub clip: Option<IjkBox>,
    /// How the cut cells are found (the slices are the same either way).
    pub cells: CellFinding,
    /// Stops the CPU sweep between levels (not part of the cache key).
    pub cancel: crate::cancel::Cancel,
}

impl SliceKey {
    /// Carries the attribute's gradient (pre-integrated volume mode).
    pub fn with_attr_gradient(mut self) -> Self {
        if !self.iso && !self.attr_gradient {
            self.attr_gradient = true;
            self.key.gradient = true;
        }
        self
    }

    /// Draws only the cells of the IJK box `clip` (cell index ranges `lo..hi`).
    pub fn with_clip(mut self, clip: Option<IjkBox>) -> Self {
        self.key.clip = clip;
        self.clip = clip;
        self
    }
}

/// The slices `o` needs along `axis` (or its isosurfaces).
pub fn slice_key(grid: &Grid, o: &RenderOptions, axis: usize) -> Result<SliceKey, RenderError> {
    let property = shown_property(grid, o);
    let (kind, field, levels) = match o.mode {
        Mode::Iso => {
            let Some(p) = &property else {
                return Err(RenderError::Options(
                    "iso mode needs a point or cell property".into(),
                ));
            };
            if o.iso.is_empty() {
                return Err(RenderError::Options("iso mode needs isovalues".into()));
            }
            let mut iso = o.iso.clone();
            iso.sort_by(f64::total_cmp);
            iso.dedup();
            (
                SliceLevels::Iso(iso.iter().map(|v| v.to_bits()).collect()),
                FieldSpec::Property(p.clone()),
                LevelSpec::Values(iso),
            )
        }
        _ => {
            if o.slices == 0 {
                return Err(RenderError::Options(
                    "the slice count must be at least 1".into(),
                ));
            }
            (
                SliceLevels::Axis {
                    axis,
                    count: o.slices,
                },
                FieldSpec::Axis {
                    axis,
                    negative: false,
                },
                LevelSpec::Count(o.slices),
            )
        }
    };
    Ok(SliceKey {
        key: SliceId {
            levels: kind,
            property: property.clone(),
            gradient: false,
            clip: None,
        },
        field,
        levels,
        property,
        iso: o.mode == Mode::Iso,
        axis,
        attr_gradient: false,
        clip: None,
        cells: o.cells,
        cancel: Default::default(),
    })
}

/// A cheap identity of a (grid, structure) pair: their addresses, sizes
/// and a hash of up to 64 evenly spaced points and property values. The
/// slice cache is keyed by view and property only, so a render of another
/// grid, or of the same one changed, must not reuse it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridStamp {
    addresses: [usize; 3],
    sizes: [usize; 2],
    sample: u64,
}

impl GridStamp {
    /// The stamp of `grid` with its structure `s`.
    pub fn of(grid: &Grid, s: &Structure) -> Self {
        fn mix(h: u64, x: u64) -> u64 {
            (h ^ x).wrapping_mul(0x0100_0000_01b3).rotate_left(17)
        }
        fn spaced(n: usize) -> impl Iterator<Item = usize> {
            let step = n.div_ceil(64).max(1);
            (0..n).step_by(step)
        }
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for i in spaced(grid.points.len()) {
            for c in grid.points[i] {
                h = mix(h, c.to_bits());
            }
        }
        for p in grid.point_data.iter().chain(&grid.cell_data) {
            h = mix(h, p.name.len() as u64);
            for i in spaced(p.len()) {
                h = mix(h, p.scalar_at(i).to_bits());
            }
        }
        GridStamp {
            addresses: [
                grid as *const Grid as usize,
                grid.points.as_ptr() as usize,
                s as *const Structure as usize,
            ],
            sizes: [grid.points.len(), grid.cell_count()],
            sample: h,
        }
    }
}
