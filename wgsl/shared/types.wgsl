// Structs shared with Rust: mirrors of src/gpu/shared.rs (sizes and member
// offsets are checked by tests/gpu/layout.rs).

struct TableSections {
    metas: u32,
    codes: u32,
    variants: u32,
    loops: u32,
    config: u32,
    edges: u32,
    face_start: u32,
    face_verts: u32,
}

struct EmitParams {
    entry_count: u32,
    level_count: u32,
    structured: u32,
    has_attribute: u32,
    slab: u32,
    hex_meta: u32,
    write_areas: u32,
    row_width: u32,
    hex_offsets_lo: vec4<u32>,
    hex_offsets_hi: vec4<u32>,
    tables: TableSections,
    triangle_capacity: u32,
    live_count: u32,
    has_gradient: u32,
    level_offset: f32,
}

struct MetaInfo {
    nv: u32,
    edge_base: u32,
    face_base: u32,
    face_count: u32,
    code_base: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Entry {
    slot: u32,
    level: u32,
}

struct OutVertex {
    pos: vec3<f32>,
    value: f32,
}

struct DrawArgs {
    vertex_count: u32,
    instance_count: u32,
    first_vertex: u32,
    first_instance: u32,
}

struct RenderParams {
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    view_dir: vec4<f32>,
    axis: vec4<f32>,
    value_lo: f32,
    value_hi: f32,
    spacing_over_unit: f32,
    perspective: u32,
    mode: u32,
    z_scale: f32,
    slab: f32,
    field_mode: u32,
}

const ATTR_NONE: u32 = 0u;
const ATTR_VERTEX: u32 = 1u;
const ATTR_CELL: u32 = 2u;
const META_WORDS: u32 = 8u;
const ARGS_WORDS: u32 = 4u;
const WORKGROUP: u32 = 64u;
const SCAN_WORKGROUP: u32 = 256u;
const MAX_META_VERTICES: u32 = 12u;
