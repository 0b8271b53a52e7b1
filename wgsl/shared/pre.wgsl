// Shared by the pre-integrated passes (after shared/draw.wgsl,
// `gpu::render::preintegrated`): the table, the scalar targets of the
// slices and of the grid's outer surface, and the integration of a
// segment from the table (along a Hermite curve, or marched through the
// index-space field on IJK grids).

// Pre-integrated slabs: PRE_SIZE × PRE_SIZE premultiplied RGBA over
// (front, back) values in [value_lo, value_hi], for slabs of
// spacing_over_unit unit distances along the axis.
@group(0) @binding(2) var<storage, read> pre: array<vec4<f32>>;
const PRE_SIZE: u32 = 128u;

// Table coordinate of a value.
fn pre_coord(v: f32) -> f32 {
    let span = rp.value_hi - rp.value_lo;
    if span <= 0.0 {
        return 0.0;
    }
    return clamp((v - rp.value_lo) / span, 0.0, 1.0) * f32(PRE_SIZE - 1u);
}

fn pre_at(f: u32, b: u32) -> vec4<f32> {
    return pre[f + PRE_SIZE * b];
}

// The far slice's scalars (fs_pre), or the nearest slice's (fs_front), and
// the ray's exit or entry distance.
@group(1) @binding(0) var scalars: texture_2d<f32>;
@group(1) @binding(1) var bound_t: texture_2d<f32>;
// fs_front: the exit target (the other groups bind the entry, unread).
@group(1) @binding(2) var other_bound_t: texture_2d<f32>;
const NO_VALUE: f32 = -3.0e38;
const SUB_SLABS: u32 = 4u;

fn view_cos(ray: vec3<f32>) -> f32 {
    return max(abs(dot(ray, rp.axis.xyz)), 1e-3);
}

// Distance along the ray from the eye (display units; orthographic: along
// view_dir from the eye's plane).
fn ray_t(disp: vec3<f32>) -> f32 {
    if rp.perspective == 1u {
        return length(disp - rp.eye.xyz);
    }
    return dot(disp - rp.eye.xyz, rp.view_dir.xyz);
}

// Bilinear table lookup: premultiplied RGBA of a sub-slab from f to b.
fn pre_table(f: f32, b: f32) -> vec4<f32> {
    let xf = pre_coord(f);
    let xb = pre_coord(b);
    let f0 = min(u32(floor(xf)), PRE_SIZE - 2u);
    let b0 = min(u32(floor(xb)), PRE_SIZE - 2u);
    let wf = xf - f32(f0);
    let wb = xb - f32(b0);
    let lo = mix(pre_at(f0, b0), pre_at(f0 + 1u, b0), wf);
    let hi = mix(pre_at(f0, b0 + 1u), pre_at(f0 + 1u, b0 + 1u), wf);
    return mix(lo, hi, wb);
}

// A sub-slab from f to b, its opacity raised to k (the ray's length
// through it over the table's).
fn sub_slab(f: f32, b: f32, k: f32) -> vec4<f32> {
    let c = pre_table(f, b);
    let a = clamp(c.a, 0.0, 1.0);
    if a <= 0.0 {
        return vec4<f32>(0.0);
    }
    let a2 = 1.0 - pow(1.0 - a, k);
    return vec4<f32>(c.rgb * (a2 / a), a2);
}

// `acc` (in front) over `c`.
fn under(acc: vec4<f32>, c: vec4<f32>) -> vec4<f32> {
    return acc + (1.0 - acc.a) * c;
}

// The cubic Hermite curve at t in [0, 1] from (v0, d0) to (v1, d1), the
// derivatives per unit t.
fn hermite(v0: f32, d0: f32, v1: f32, d1: f32, t: f32) -> f32 {
    let t2 = t * t;
    let t3 = t2 * t;
    return (2.0 * t3 - 3.0 * t2 + 1.0) * v0 + (t3 - 2.0 * t2 + t) * d0
        + (3.0 * t2 - 2.0 * t3) * v1 + (t3 - t2) * d1;
}

// A straight segment x display units long starting at value v, `slope`
// per display unit, in sub-slabs of at most `sub` (the table's length
// along the ray, opacity exponent k for that length).
fn segment(v: f32, slope: f32, x: f32, sub: f32, k: f32) -> vec4<f32> {
    var acc = vec4<f32>(0.0);
    if x <= 0.0 {
        return acc;
    }
    let m = clamp(u32(ceil(x / sub)), 1u, 4u * SUB_SLABS);
    let h = x / f32(m);
    for (var i = 0u; i < m; i++) {
        let a = f32(i) * h;
        acc = under(acc, sub_slab(v + slope * a, v + slope * (a + h), k * h / sub));
    }
    return acc;
}

// IJK grids (rp.field_mode != 0, `gpu::render::preintegrated::ijk_field`): the shown property in
// index space, one texel per vertex (FIELD_POINT, trilinear) or per cell
// (FIELD_CELL, piecewise constant; NO_VALUE: hidden). The slices carry
// their corners' (i, j, k) in `normal`, the scalar targets hold (i, j, k,
// ray distance) and the entry/exit targets (ray distance, i, j, k), so a
// slab is marched through the field from this slice's index point to the
// far slice's.
@group(2) @binding(0) var field_t: texture_3d<f32>;
@group(2) @binding(1) var field_s: sampler;
const FIELD_POINT: u32 = 1u;
const FIELD_CELL: u32 = 2u;
// Point fields: sub-steps per cell crossed, and at most this many per segment.
const STEPS_PER_CELL: f32 = 2.0;
const MAX_STEPS: u32 = 64u;

fn field_load(c: vec3<i32>) -> f32 {
    return textureLoad(field_t, c, 0).x;
}

// The trilinear field at index point p (the sampler clamps to the
// lattice; texel centres sit at index + 0.5).
fn field_point(p: vec3<f32>) -> f32 {
    let dims = vec3<f32>(textureDimensions(field_t));
    return textureSampleLevel(field_t, field_s, (p + 0.5) / dims, 0.0).x;
}

// The cell containing index point p (clamped to the lattice).
fn field_cell(p: vec3<f32>) -> f32 {
    let dims = vec3<i32>(textureDimensions(field_t));
    return field_load(clamp(vec3<i32>(floor(p)), vec3<i32>(0), dims - 1));
}

// A constant segment x display units long: the transfer colour, opacity
// corrected for its length in unit distances.
fn constant_segment(v: f32, x: f32) -> vec4<f32> {
    if v <= 0.5 * NO_VALUE || x <= 0.0 {
        return vec4<f32>(0.0);
    }
    let c = transfer(v);
    let a = 1.0 - pow(1.0 - clamp(c.a, 0.0, 1.0), x * rp.spacing_over_unit / rp.slab);
    return vec4<f32>(c.rgb * a, a);
}

// The next parameter in (s, 1] where the segment a + s·d crosses an integer
// plane of axis c (1 when it does not).
fn next_plane(a: f32, d: f32, s: f32) -> f32 {
    if abs(d) < 1e-6 {
        return 1.0;
    }
    let p = a + d * s;
    var plane = ceil(p - 1e-4) - 1.0;
    if d > 0.0 {
        plane = floor(p + 1e-4) + 1.0;
    }
    return min((plane - a) / d, 1.0);
}

// The ray from index point a (point field value va there) to b, x display
// units long, through the
// field: a cell field exactly, cell by cell; a point field in sub-steps
// (STEPS_PER_CELL per cell crossed, none longer than the table's sub-slab
// l0), each from the pre-integrated table between its end samples.
fn march(a: vec3<f32>, va: f32, b: vec3<f32>, x: f32, l0: f32) -> vec4<f32> {
    var acc = vec4<f32>(0.0);
    if x <= 0.0 {
        return acc;
    }
    let d = b - a;
    if rp.field_mode == FIELD_CELL {
        var s = 0.0;
        for (var it = 0u; it < MAX_STEPS && s < 1.0; it++) {
            var next = min(next_plane(a.x, d.x, s), next_plane(a.y, d.y, s));
            next = max(min(next, next_plane(a.z, d.z, s)), s + 1e-3);
            let v = field_cell(a + d * (0.5 * (s + min(next, 1.0))));
            acc = under(acc, constant_segment(v, x * (min(next, 1.0) - s)));
            s = next;
        }
        return acc;
    }
    let n = clamp(u32(ceil(STEPS_PER_CELL * length(d))), 1u, MAX_STEPS);
    let h = 1.0 / f32(n);
    var f = va;
    for (var i = 1u; i <= n; i++) {
        let v = field_point(a + d * (f32(i) * h));
        acc = under(acc, sub_slab(f, v, x * h / l0));
        f = v;
    }
    return acc;
}
