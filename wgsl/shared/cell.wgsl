// Bindings and per-cell logic shared by the count and emit passes
// (mirrored by src/gpu/twin.rs). Prepended with `alias real = f64;` (or f32
// on adapters without SHADER_F64) and wgsl/shared/types.wgsl.

@group(0) @binding(0) var<uniform> params: EmitParams;
@group(0) @binding(1) var<storage, read> tables: array<u32>;
// xyz: rebased position, w: φ.
@group(0) @binding(2) var<storage, read> grid: array<vec4<f32>>;
// Per vertex (ATTR_VERTEX) or per slot (ATTR_CELL), see EmitParams.
@group(0) @binding(3) var<storage, read> attr: array<f32>;
// CGraph: per slot (meta id, first vertex word), then the vertex ids.
@group(0) @binding(4) var<storage, read> cells: array<u32>;
@group(0) @binding(5) var<storage, read_write> entries: array<Entry>;
@group(0) @binding(6) var<storage, read_write> control: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read_write> out_vertices: array<OutVertex>;
@group(0) @binding(8) var<storage, read_write> out_areas: array<f32>;
@group(0) @binding(9) var<storage, read> levels: array<f32>;
// Span-space passes: the live slots.
@group(0) @binding(10) var<storage, read> live: array<u32>;
// Iso lighting (has_gradient == 1): per vertex the field's gradient (xyz),
// and per output corner the gradient interpolated along the cut edge.
@group(0) @binding(11) var<storage, read> grad: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> out_normals: array<vec4<f32>>;

// Control buffer layout (src/gpu/shared.rs ControlLayout).
fn ctl_args_rev() -> u32 { return ARGS_WORDS * params.level_count; }
fn ctl_tri_count() -> u32 { return 2u * ARGS_WORDS * params.level_count; }
fn ctl_poly_count() -> u32 { return ctl_tri_count() + params.level_count; }
fn ctl_cursor() -> u32 { return ctl_poly_count() + params.level_count; }
fn ctl_base() -> u32 { return ctl_cursor() + params.level_count; }
fn ctl_total() -> u32 { return ctl_base() + params.level_count; }
fn ctl_bin_total() -> u32 { return ctl_total() + 1u; }
fn ctl_bin_cursor() -> u32 { return ctl_total() + 2u; }

// The current cell: global vertex ids and φ in local order.
var<private> c_ids: array<u32, 12>;
var<private> c_phi: array<f32, 12>;

fn load_meta(m: u32) -> MetaInfo {
    let b = params.tables.metas + m * META_WORDS;
    return MetaInfo(tables[b], tables[b + 1u], tables[b + 2u], tables[b + 3u], tables[b + 4u], 0u, 0u, 0u);
}

// extract::face_above_connected on the face whose local vertices are
// face_verts[start .. start + n]: quads by the bilinear saddle, larger faces
// by the mean (summed in global-id order), ties to the smallest global id.
fn face_above_connected(start: u32, n: u32, t: f32) -> bool {
    let fv = params.tables.face_verts + start;
    var g: array<u32, 12>;
    var v: array<f32, 12>;
    for (var i = 0u; i < n; i++) {
        let l = tables[fv + i];
        g[i] = c_ids[l];
        v[i] = c_phi[l];
    }
    var verdict = 0;
    let tt = real(t);
    if n == 4u {
        var fa = v[1];
        var fc = v[3];
        var fb = v[0];
        var fd = v[2];
        if v[0] >= t {
            fa = v[0];
            fc = v[2];
            fb = v[1];
            fd = v[3];
        }
        let num = real(fa) * real(fc) - real(fb) * real(fd);
        let den = (real(fa) + real(fc)) - (real(fb) + real(fd));
        let rhs = tt * den;
        if num > rhs {
            verdict = 1;
        } else if num < rhs {
            verdict = -1;
        }
    } else {
        // Insertion sort by global id, then the sum in that order.
        for (var i = 1u; i < n; i++) {
            let kg = g[i];
            let kv = v[i];
            var j = i;
            while j > 0u && g[j - 1u] > kg {
                g[j] = g[j - 1u];
                v[j] = v[j - 1u];
                j--;
            }
            g[j] = kg;
            v[j] = kv;
        }
        var sum = real(0.0);
        for (var i = 0u; i < n; i++) {
            sum += real(v[i]);
        }
        let mean = sum / real(n);
        if mean > tt {
            verdict = 1;
        } else if mean < tt {
            verdict = -1;
        }
    }
    if verdict == 1 {
        return true;
    }
    if verdict == -1 {
        return false;
    }
    var best = 0u;
    for (var i = 1u; i < n; i++) {
        if g[i] < g[best] {
            best = i;
        }
    }
    return v[best] >= t;
}

// Decider bits of the ambiguous faces `mask` (one bit per face, in
// increasing face order), as extract::decide_faces.
fn decide_faces(mi: MetaInfo, amb: u32, t: f32) -> u32 {
    var outcome = 0u;
    var mask = amb;
    var bit = 0u;
    loop {
        if mask == 0u {
            break;
        }
        let f = countTrailingZeros(mask);
        mask &= mask - 1u;
        let fs = params.tables.face_start + mi.face_base + f;
        let a = tables[fs];
        let b = tables[fs + 1u];
        if face_above_connected(a, b - a, t) {
            outcome |= 1u << bit;
        }
        bit++;
    }
    return outcome;
}

// Loads the vertex ids and φ of the cell in `slot` into c_ids / c_phi;
// returns (meta id, vertex count).
fn load_cell(slot: u32) -> vec2<u32> {
    var m = params.hex_meta;
    var nv = 8u;
    if params.structured == 1u {
        let v0 = slot - params.slab;
        for (var i = 0u; i < 4u; i++) {
            c_ids[i] = v0 + params.hex_offsets_lo[i];
            c_ids[i + 4u] = v0 + params.hex_offsets_hi[i];
        }
    } else {
        m = cells[2u * slot];
        let start = cells[2u * slot + 1u];
        nv = load_meta(m).nv;
        for (var i = 0u; i < nv; i++) {
            c_ids[i] = cells[start + i];
        }
    }
    for (var i = 0u; i < nv; i++) {
        c_phi[i] = grid[c_ids[i]].w;
    }
    return vec2<u32>(m, nv);
}

// Loads the cell of entry `e` and returns (global variant, meta id) for
// level value t.
fn cell_variant(e: Entry, t: f32) -> vec2<u32> {
    let mn = load_cell(e.slot);
    let m = mn.x;
    var code = 0u;
    for (var i = 0u; i < mn.y; i++) {
        if c_phi[i] >= t {
            code |= 1u << i;
        }
    }
    let mi = load_meta(m);
    let ci = params.tables.codes + mi.code_base + 2u * code;
    let amb = tables[ci];
    var variant = tables[ci + 1u];
    if amb != 0u {
        variant += decide_faces(mi, amb, t);
    }
    return vec2<u32>(variant, m);
}

// Triangles of the loops of a variant: sum of (config_size − 2).
fn variant_triangles(variant: u32) -> u32 {
    let l0 = tables[params.tables.variants + variant];
    let l1 = tables[params.tables.variants + variant + 1u];
    var tris = 0u;
    for (var l = l0; l < l1; l++) {
        tris += tables[params.tables.loops + 2u * l + 1u] - 2u;
    }
    return tris;
}

fn entry_index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * params.row_width;
}
