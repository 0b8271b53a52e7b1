//! Every struct shared between Rust and WGSL, in one place.
//!
//! Each struct is `#[repr(C)]` + [`bytemuck::Pod`] and mirrors a struct of
//! the same name in `wgsl/shared/types.wgsl`; `tests/gpu/layout.rs` checks
//! with naga that sizes and member offsets agree. The constants describe the
//! layout of the flat `u32` buffers (tables, cells, control) that both the
//! WGSL passes and the CPU twin (`gpu::compute::twin`) index.

use bytemuck::{Pod, Zeroable};

/// Parameters of one emission frame (uniform buffer, binding 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EmitParams {
    /// Number of (slot, level) entries in this frame.
    pub entry_count: u32,
    /// Number of levels in this frame.
    pub level_count: u32,
    /// 1 for an S-CGraph (implicit hexahedra), 0 for a CGraph (`cells` buffer).
    pub structured: u32,
    /// What the `attr` buffer holds: [`ATTR_NONE`] (write the level value),
    /// [`ATTR_VERTEX`] (one value per vertex, interpolated along the cut
    /// edge) or [`ATTR_CELL`] (one value per slot, written flat on every
    /// corner of the cell's polygons).
    pub has_attribute: u32,
    /// S-CGraph: `npi · npj` (slot of cell (i, j, k) minus the vertex id of its first vertex).
    pub slab: u32,
    /// S-CGraph: meta-cell id of its cells (the hexahedron).
    pub hex_meta: u32,
    /// 1 to write one polygon-area share per triangle into `out_areas`.
    pub write_areas: u32,
    /// Threads per row of a 2D dispatch (`workgroups_x · 64`).
    pub row_width: u32,
    /// S-CGraph: vertex id offsets of local vertices 0..4 from the cell's first vertex.
    pub hex_offsets_lo: [u32; 4],
    /// S-CGraph: vertex id offsets of local vertices 4..8.
    pub hex_offsets_hi: [u32; 4],
    /// Section starts inside the `tables` buffer (see [`TableSections`]).
    pub tables: TableSections,
    /// Capacity of `out_vertices` in triangles (emission never writes past it).
    pub triangle_capacity: u32,
    /// Span-space passes: live cells in the `live` buffer.
    pub live_count: u32,
    /// 1 when the `grad` buffer holds a gradient per vertex: the emit pass
    /// then interpolates it along the cut edge into `out_normals`.
    pub has_gradient: u32,
    /// [`ATTR_NONE`]: added to the local level to write its world value
    /// (see [`crate::pipeline::level_value`]).
    pub level_offset: f32,
}

/// [`EmitParams::has_attribute`]: no attribute, write the level value
/// (the local level plus [`EmitParams::level_offset`]).
pub const ATTR_NONE: u32 = 0;
/// [`EmitParams::has_attribute`]: one value per vertex, interpolated.
pub const ATTR_VERTEX: u32 = 1;
/// [`EmitParams::has_attribute`]: one value per slot (the cell's own), flat.
pub const ATTR_CELL: u32 = 2;

/// Start (in `u32`s) of each section of the flat `tables` buffer that holds
/// the meta-cell catalog (see `gpu::compute::tables`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TableSections {
    /// [`MetaInfo`] records, [`META_WORDS`] words each.
    pub metas: u32,
    /// Per meta-cell and code: (ambiguous face mask, first global variant).
    pub codes: u32,
    /// Per global variant: its first global loop; one sentinel at the end.
    pub variants: u32,
    /// Per global loop: (start in `config`, `config_size`).
    pub loops: u32,
    /// Local edge ids of the loops (the paper's `config`).
    pub config: u32,
    /// Per meta-cell edge: local vertices `a | b << 16` with `a < b`.
    pub edges: u32,
    /// Per meta-cell face: start in `face_verts`; one sentinel per meta-cell.
    pub face_start: u32,
    /// Local vertex ids of the faces (outward loops).
    pub face_verts: u32,
}

/// One meta-cell's record in the `tables` buffer.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MetaInfo {
    /// Local vertex count.
    pub nv: u32,
    /// Its first edge in the edges section.
    pub edge_base: u32,
    /// Its first face in the face_start section.
    pub face_base: u32,
    /// Its face count.
    pub face_count: u32,
    /// Its code 0 in the codes section (pairs: index `code_base + 2·code`).
    pub code_base: u32,
    /// Padding.
    pub _pad0: u32,
    /// Padding.
    pub _pad1: u32,
    /// Padding.
    pub _pad2: u32,
}

/// Words per [`MetaInfo`] record.
pub const META_WORDS: u32 = (std::mem::size_of::<MetaInfo>() / 4) as u32;

/// One unit of work: cell `slot` at level `level` of the frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Pod, Zeroable)]
pub struct Entry {
    /// Structure slot of an intersected cell.
    pub slot: u32,
    /// Level index in the frame.
    pub level: u32,
}

/// One output vertex: position (local frame) and interpolated property.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct OutVertex {
    /// Position, local (rebased) frame.
    pub pos: [f32; 3],
    /// Interpolated attribute (or the level value).
    pub value: f32,
}

/// [`OutVertex`] as a vertex buffer: location 0 the position, 1 the value.
pub fn out_vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRS: [wgpu::VertexAttribute; 2] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32];
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<OutVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRS,
    }
}

/// The emit pass's normals (one `vec4<f32>` per corner) as a vertex
/// buffer at location 2.
pub fn normal_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRS: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![2 => Float32x3];
    wgpu::VertexBufferLayout {
        array_stride: 16,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRS,
    }
}

/// `wgpu::util::DrawIndirectArgs`, as written by the scan pass.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct DrawArgs {
    /// Vertices to draw (3 per triangle).
    pub vertex_count: u32,
    /// Always 1.
    pub instance_count: u32,
    /// First vertex of the level's region.
    pub first_vertex: u32,
    /// Always 0 (non-zero needs `INDIRECT_FIRST_INSTANCE`).
    pub first_instance: u32,
}

/// Words per [`DrawArgs`].
pub const ARGS_WORDS: u32 = 4;

/// Layout of the `control` buffer (`u32` words) for `k` levels: draw
/// arguments in increasing level order, then in decreasing order, then the
/// per-level counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ControlLayout {
    /// Level count.
    pub k: u32,
}

impl ControlLayout {
    /// Word of the increasing-order [`DrawArgs`] array.
    pub fn args_fwd(&self) -> u32 {
        0
    }
    /// Word of the decreasing-order [`DrawArgs`] array.
    pub fn args_rev(&self) -> u32 {
        ARGS_WORDS * self.k
    }
    /// Word of the per-level triangle counters (count pass).
    pub fn tri_count(&self) -> u32 {
        2 * ARGS_WORDS * self.k
    }
    /// Word of the per-level polygon counters (count pass).
    pub fn poly_count(&self) -> u32 {
        self.tri_count() + self.k
    }
    /// Word of the per-level emission cursors (emit pass).
    pub fn cursor(&self) -> u32 {
        self.poly_count() + self.k
    }
    /// Word of the per-level first triangle (scan pass).
    pub fn base(&self) -> u32 {
        self.cursor() + self.k
    }
    /// Word of the total triangle count (scan pass).
    pub fn total(&self) -> u32 {
        self.base() + self.k
    }
    /// Word of the span-space entry total (bin count pass).
    pub fn bin_total(&self) -> u32 {
        self.total() + 1
    }
    /// Total words.
    pub fn words(&self) -> u32 {
        self.total() + 4
    }
}

/// Work-group size of the compute passes.
pub const WORKGROUP: u32 = 64;
/// Work-group size of the scan pass (one work group).
pub const SCAN_WORKGROUP: u32 = 256;

/// Uniforms of the render pass (binding 0 of the render pipeline).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderParams {
    /// World (local frame) → clip matrix, column-major.
    pub view_proj: [[f32; 4]; 4],
    /// Eye position (perspective) in the local frame.
    pub eye: [f32; 4],
    /// View direction (orthographic rays), unit, xyz.
    pub view_dir: [f32; 4],
    /// Unit normal of the slicing axis, xyz.
    pub axis: [f32; 4],
    /// Transfer function domain: min value.
    pub value_lo: f32,
    /// Transfer function domain: max value.
    pub value_hi: f32,
    /// Slice spacing Δ along the axis divided by the unit distance U.
    pub spacing_over_unit: f32,
    /// 1 = perspective (per-fragment ray), 0 = orthographic.
    pub perspective: u32,
    /// 0 = volume (opacity-corrected), 1 = slices (opacity as is), 2 = iso (opaque, lit).
    pub mode: u32,
    /// Vertical exaggeration S: display z = S × local z (rays, normals).
    pub z_scale: f32,
    /// Pre-integrated volume mode: display-space slab thickness (Δ × LOD
    /// × the z-scale along z); 0 for the plain mode.
    pub slab: f32,
    /// Pre-integrated mode on an IJK grid: 1 = the slices carry `(i, j,
    /// k)` and a point property's texels are read trilinearly, 2 = a cell
    /// property's piecewise constant; 0 = no index-space field.
    pub field_mode: u32,
}
