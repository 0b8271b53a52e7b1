// Shared by the render passes (after shared/types.wgsl): the parameters,
// the transfer function's lookup table, the vertex stages of the slices
// (vs: position and value; vs_iso: with the emit pass's per-corner
// gradient or (i, j, k) as a second vertex buffer) and their output.
// Vertical exaggeration: view_proj scales z itself; rays, the eye and
// normals are taken in display space (z × z_scale).

@group(0) @binding(0) var<uniform> rp: RenderParams;
// Transfer function (`gpu::render::transfer`): lut[0].x knots n; lut[1 + i] the
// straight RGBA of knot i; its position in lut[1 + LUT_KNOTS + i / 4][i % 4],
// ascending. Piecewise linear between knots, clamped outside.
@group(0) @binding(1) var<storage, read> lut: array<vec4<f32>>;

const LUT_KNOTS: u32 = 1024u;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) value: f32,
    @location(2) normal: vec3<f32>,
}

fn vertex_out(pos: vec3<f32>, value: f32, normal: vec3<f32>) -> VsOut {
    var o: VsOut;
    o.clip = rp.view_proj * vec4<f32>(pos, 1.0);
    o.world = pos;
    o.value = value;
    o.normal = normal;
    return o;
}

@vertex
fn vs(@location(0) pos: vec3<f32>, @location(1) value: f32) -> VsOut {
    return vertex_out(pos, value, vec3<f32>(0.0));
}

// Iso mode: the per-corner gradient comes from the emit pass's normals.
@vertex
fn vs_iso(@location(0) pos: vec3<f32>, @location(1) value: f32, @location(2) normal: vec3<f32>) -> VsOut {
    return vertex_out(pos, value, normal);
}

fn knot_pos(i: u32) -> f32 {
    return lut[1u + LUT_KNOTS + i / 4u][i % 4u];
}

fn transfer(v: f32) -> vec4<f32> {
    let n = min(u32(lut[0].x), LUT_KNOTS);
    // NaN (an infinite value interpolated against its opposite): nothing.
    if n == 0u || (bitcast<u32>(v) & 0x7fffffffu) > 0x7f800000u {
        return vec4<f32>(0.0);
    }
    if v <= knot_pos(0u) {
        return lut[1u];
    }
    if v >= knot_pos(n - 1u) {
        return lut[n];
    }
    // knot_pos(lo) < v < knot_pos(hi).
    var lo = 0u;
    var hi = n - 1u;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if knot_pos(mid) <= v {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = knot_pos(lo);
    let b = knot_pos(hi);
    // Halved so that ends near ±f32::MAX do not overflow.
    let f = clamp((0.5 * v - 0.5 * a) / (0.5 * b - 0.5 * a), 0.0, 1.0);
    return mix(lut[1u + lo], lut[1u + hi], f);
}
