//! The shown property as a 3D texture in IJK index space, for the
//! pre-integrated volume pass on IJK (S-CGraph) grids.
//!
//! A point property gets one texel per vertex (texel `(i, j, k)` is vertex
//! `i + npi·(j + npj·k)`), sampled with the hardware's trilinear filter in
//! `wgsl/shared/pre.wgsl`: the grid's own trilinear field in index space
//! (`R32Float`, so the adapter must have `FLOAT32_FILTERABLE`). A cell
//! property gets one texel per cell, read as the exact piecewise-constant
//! field; hidden cells hold [`NO_CELL`] (transparent). The slices carry
//! each corner's index coordinate `(i, j, k)` in place of the attribute's
//! gradient (the emit pass interpolates it along the cut edge like the
//! value), so a slab is marched in index space from this slice's point to
//! the far slice's. Corner-point graphs (CP-Graph) take cell properties
//! (their vertices' nodes: `structures::cpgraph::ijk`). Other grids (zoo,
//! Voronoi, CGraph, CIEL), point properties on corner-point grids, lattices
//! over `max_texture_dimension_3d` and adapters without the filter keep the
//! gradient path (or plain slices for a cell property), with the reason on
//! the slice set.

use crate::cellgraph::CellGraph;
use crate::grid::Grid;
use crate::structures::Structure;
use crate::structures::cpgraph::CpGraph;
use crate::structures::scgraph::SCGraph;

use crate::gpu::context::GpuContext;

/// Texel value of a hidden cell (`NO_VALUE` in `wgsl/shared/pre.wgsl`).
pub const NO_CELL: f32 = -3.0e38;

/// What the texels are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldKind {
    /// One texel per vertex, trilinear.
    Point,
    /// One texel per cell, piecewise constant.
    Cell,
}

impl FieldKind {
    /// `RenderParams::field_mode`: 1 point, 2 cell.
    pub fn mode(self) -> u32 {
        match self {
            FieldKind::Point => 1,
            FieldKind::Cell => 2,
        }
    }
}

/// The texels of the shown property of an S-CGraph (no wgpu).
#[derive(Clone, Debug, PartialEq)]
pub struct FieldTexels {
    /// Point or cell texels.
    pub kind: FieldKind,
    /// Texels along I, J, K.
    pub dims: [u32; 3],
    /// I fastest, then J, then K.
    pub values: Vec<f32>,
}

/// The texels of `property` on `g` (built from `grid`), or why not: a cell
/// property is read from `grid`'s cells, a point property from its points.
pub fn field_texels(grid: &Grid, g: &SCGraph, property: &str) -> Result<FieldTexels, String> {
    let [npi, npj, npk] = g.dims;
    if let Some(p) = grid.point_property(property) {
        return Ok(FieldTexels {
            kind: FieldKind::Point,
            dims: [npi, npj, npk].map(|n| n as u32),
            values: (0..p.len()).map(|i| p.scalar_at(i) as f32).collect(),
        });
    }
    let Some(c) = grid.cell_property(property) else {
        return Err(format!("no property '{property}'"));
    };
    let [nci, ncj, nck] = [npi - 1, npj - 1, npk - 1];
    if c.len() != nci * ncj * nck {
        return Err(format!(
            "the cell property '{property}' has {} values for {} cells",
            c.len(),
            nci * ncj * nck
        ));
    }
    let slab = npi * npj;
    let values = (0..c.len())
        .map(|cid| {
            let (i, j, k) = (cid % nci, (cid / nci) % ncj, cid / (nci * ncj));
            let slot = (i + j * npi + k * slab + slab) as u32;
            if g.is_live(slot) {
                c.scalar_at(cid) as f32
            } else {
                NO_CELL
            }
        })
        .collect();
    Ok(FieldTexels {
        kind: FieldKind::Cell,
        dims: [nci, ncj, nck].map(|n| n as u32),
        values,
    })
}

/// The cell texels of `property` on a corner-point graph: IJK cell
/// `(i, j, k)` holds its input cell's value, [`NO_CELL`] where the IJK box
/// has no input cell. Point properties are refused (a faulted pillar holds
/// several vertices per node).
pub fn cp_texels(grid: &Grid, g: &CpGraph, property: &str) -> Result<FieldTexels, String> {
    if grid.point_property(property).is_some() {
        return Err(format!(
            "'{property}' is a point property on a corner-point grid (no one value per node)"
        ));
    }
    let Some(c) = grid.cell_property(property) else {
        return Err(format!("no property '{property}'"));
    };
    let inputs = g.input_slots();
    if c.len() != inputs.len() {
        return Err(format!(
            "the cell property '{property}' has {} values for {} cells",
            c.len(),
            inputs.len()
        ));
    }
    let [nx, ny, nz] = g.dims;
    let mut values = vec![NO_CELL; nx * ny * nz];
    for (cell, &slot) in inputs.iter().enumerate() {
        let [i, j, k] = g.slot_ijk(slot);
        values[i + nx * (j + ny * k)] = c.scalar_at(cell) as f32;
    }
    Ok(FieldTexels {
        kind: FieldKind::Cell,
        dims: [nx, ny, nz].map(|n| n as u32),
        values,
    })
}

/// Per vertex of an `npi × npj × npk` lattice (I fastest): `(i, j, k, 0)`,
/// what the slices carry in place of the gradient.
pub fn vertex_ijk(dims: [usize; 3]) -> Vec<[f32; 4]> {
    let [npi, npj, npk] = dims;
    let mut out = Vec::with_capacity(npi * npj * npk);
    for k in 0..npk {
        for j in 0..npj {
            for i in 0..npi {
                out.push([i as f32, j as f32, k as f32, 0.0]);
            }
        }
    }
    out
}

/// The shown property as a 3D texture on the GPU.
pub struct IjkField {
    /// Point or cell texels.
    pub kind: FieldKind,
    /// The texture's view (`R32Float`, filtered linearly for point texels).
    pub view: wgpu::TextureView,
}

impl IjkField {
    /// The texture of `property` on `s` and the `(i, j, k)` of each of
    /// its vertices, or why the pre-integrated pass keeps the gradient
    /// path: no IJK lattice (S-CGraph, or CP-Graph for cell properties),
    /// no such property, or a side over the device's
    /// `max_texture_dimension_3d`.
    pub fn new(
        ctx: &GpuContext,
        grid: &Grid,
        s: &Structure,
        property: Option<&str>,
    ) -> Result<(Self, Vec<[f32; 4]>), String> {
        let Some(property) = property else {
            return Err("no property shown".into());
        };
        let t = match s {
            Structure::SCGraph(g) => field_texels(grid, g, property)?,
            Structure::CpGraph(g) => cp_texels(grid, g, property)?,
            _ => return Err("the grid has no IJK lattice (S-CGraph or CP-Graph)".into()),
        };
        if !ctx
            .device
            .features()
            .contains(wgpu::Features::FLOAT32_FILTERABLE)
        {
            return Err("the adapter cannot filter R32Float textures".into());
        }
        let max = ctx.limits.max_texture_dimension_3d;
        if t.dims.iter().any(|&n| n > max || n == 0) {
            return Err(format!(
                "the {:?} lattice {:?} exceeds the device's 3D texture limit {max}",
                t.kind, t.dims
            ));
        }
        let size = wgpu::Extent3d {
            width: t.dims[0],
            height: t.dims[1],
            depth_or_array_layers: t.dims[2],
        };
        let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("ijk field"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&t.values),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * t.dims[0]),
                rows_per_image: Some(t.dims[1]),
            },
            size,
        );
        let ijk = match s {
            Structure::SCGraph(g) => vertex_ijk(g.dims),
            Structure::CpGraph(g) => g.vertex_ijk(),
            _ => unreachable!("refused above"),
        };
        let field = IjkField {
            kind: t.kind,
            view: texture.create_view(&Default::default()),
        };
        Ok((field, ijk))
    }
}

/// The layout of the field texture's bind group (group 2 of `fs_pre`):
/// the texture and a linear clamping sampler.
pub fn field_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("ijk field"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D3,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
        ],
    })
}

/// The field's sampler: trilinear, clamped to the lattice.
pub fn field_sampler(device: &wgpu::Device) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("ijk field"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    })
}

/// A 1×1×1 field texture's view for frames without a field (never read;
/// `R16Float`, filterable on every adapter).
pub fn empty_field(device: &wgpu::Device) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("no ijk field"),
            size: wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::R16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Property, Topology};

    fn lattice(dims: [usize; 3]) -> Grid {
        let mut points = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    points.push([i as f64 * 2.0, j as f64, k as f64 * 0.5]);
                }
            }
        }
        let nc = (dims[0] - 1) * (dims[1] - 1) * (dims[2] - 1);
        Grid {
            point_data: vec![Property::scalar(
                "p",
                points.iter().map(|p| p[0] + 10.0 * p[2]).collect(),
            )],
            cell_data: vec![Property::scalar("c", (0..nc).map(|c| c as f64).collect())],
            points,
            topology: Topology::Structured { dims },
        }
    }

    #[test]
    fn texels_follow_the_lattice_order() {
        let dims = [4, 3, 5];
        let grid = lattice(dims);
        let g = SCGraph::build(&grid, None).unwrap();
        let p = field_texels(&grid, &g, "p").unwrap();
        assert_eq!((p.kind, p.dims), (FieldKind::Point, [4, 3, 5]));
        let ijk = vertex_ijk(dims);
        for (v, (t, c)) in p.values.iter().zip(&ijk).enumerate() {
            // Texel (i, j, k) is vertex (i, j, k): x = 2i, z = k/2.
            assert_eq!(*t, (2.0 * c[0] + 5.0 * c[2]), "vertex {v}");
            assert_eq!(
                grid.points[v],
                [2.0 * c[0] as f64, c[1] as f64, 0.5 * c[2] as f64]
            );
        }
        let c = field_texels(&grid, &g, "c").unwrap();
        assert_eq!((c.kind, c.dims), (FieldKind::Cell, [3, 2, 4]));
        assert_eq!(c.values, (0..24).map(|v| v as f32).collect::<Vec<_>>());
        assert!(field_texels(&grid, &g, "nope").is_err());
    }

    #[test]
    fn hidden_cells_are_transparent_texels() {
        let grid = lattice([3, 3, 3]);
        let mut hidden = vec![false; 8];
        hidden[5] = true;
        let g = SCGraph::build(&grid, Some(&hidden)).unwrap();
        let c = field_texels(&grid, &g, "c").unwrap();
        for (i, v) in c.values.iter().enumerate() {
            assert_eq!(*v, if i == 5 { NO_CELL } else { i as f32 }, "cell {i}");
        }
    }
}
