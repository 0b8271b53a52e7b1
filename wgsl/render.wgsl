// Render pass: the emitted triangles (OutVertex) drawn with indirect draws.
// Volume mode: transfer-function colour with opacity corrected for the
// slice spacing and the angle between the ray and the slicing axis,
// premultiplied for "over" blending. Slices mode: opacity as is. Iso mode
// (vs_iso): opaque, lit with the field's gradient interpolated along the cut
// edges by the emit pass (a second vertex buffer), then across the triangle.
// Vertical exaggeration: view_proj scales z itself; rays, the eye and
// normals are taken in display space (z × z_scale).

@group(0) @binding(0) var<uniform> rp: RenderParams;
// Transfer function (`gpu::transfer`): lut[0].x knots n; lut[1 + i] the
// straight RGBA of knot i; its position in lut[1 + LUT_KNOTS + i / 4][i % 4],
// ascending. Piecewise linear between knots, clamped outside.
@group(0) @binding(1) var<storage, read> lut: array<vec4<f32>>;

const LUT_KNOTS: u32 = 1024u;

// Pre-integrated slabs: PRE_SIZE × PRE_SIZE premultiplied RGBA over
// (front, back) values in [value_lo, value_hi], for slabs of
// spacing_over_unit unit distances along the axis.
@group(0) @binding(2) var<storage, read> pre: array<vec4<f32>>;
const PRE_SIZE: u32 = 128u;

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

@fragment
fn fs(in: VsOut) -> @location(0) vec4<f32> {
    let c = transfer(in.value);
    // Display space: z exaggerated by z_scale (rays, eye and normals).
    let disp = vec3<f32>(in.world.xy, in.world.z * rp.z_scale);
    var ray = rp.view_dir.xyz;
    if rp.perspective == 1u {
        ray = normalize(disp - rp.eye.xyz);
    }
    if rp.mode == 2u {
        // The interpolated gradient; the facet normal where it vanishes.
        var n = cross(dpdx(disp), dpdy(disp));
        if dot(in.normal, in.normal) > 1e-30 {
            // A gradient transforms with the inverse scale.
            n = vec3<f32>(in.normal.xy, in.normal.z / rp.z_scale);
        }
        n = normalize(n);
        // Two-sided headlight: ambient + diffuse.
        let shade = 0.2 + 0.8 * abs(dot(n, ray));
        return vec4<f32>(c.rgb * shade, 1.0);
    }
    var a = clamp(c.a, 0.0, 1.0);
    if rp.mode == 0u {
        let cosv = max(abs(dot(ray, rp.axis.xyz)), 1e-3);
        a = 1.0 - pow(1.0 - a, rp.spacing_over_unit / cosv);
    }
    return vec4<f32>(c.rgb * a, a);
}

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

// Pre-integrated volume mode (`gpu::pre_pass`): one pass per slice, far
// to near. The slab behind this slice runs to the far slice at the same
// pixel, whose value, derivative along the ray and ray distance the
// previous pass wrote (NO_VALUE: no far slice there). Inside, the value
// follows the cubic Hermite curve of both ends, composited as SUB_SLABS
// sub-slabs from the table (built for a sub-slab along view_dir;
// perspective rays are corrected relative to it). Without a far slice the
// segment runs to where the ray leaves the grid (the outer surface's
// farthest distance; half a slab when unknown). Each slice's scalars also
// go to the nearest-slice target, which fs_front reads last to add the
// segment from where the ray enters the grid to the nearest slice.
@group(1) @binding(0) var scalars: texture_2d<f32>;
@group(1) @binding(1) var bound_t: texture_2d<f32>;
// fs_front: the exit target (the other groups bind the entry, unread).
@group(1) @binding(2) var other_bound_t: texture_2d<f32>;
const NO_VALUE: f32 = -3.0e38;
const SUB_SLABS: u32 = 4u;

struct PreOut {
    @location(0) color: vec4<f32>,
    @location(1) slice: vec4<f32>,
    @location(2) nearest: vec4<f32>,
}

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

// IJK grids (rp.field_mode != 0, `gpu::ijk_field`): the shown property in
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

// fs_pre on an IJK grid: the slab to the far slice (or to the ray's exit)
// marched through the field.
fn pre_ijk(ijk: vec3<f32>, v: f32, t: f32, far: vec4<f32>, px: vec2<i32>, len: f32) -> vec4<f32> {
    let l0 = rp.slab / view_cos(rp.view_dir.xyz) / f32(SUB_SLABS);
    if far.x > 0.5 * NO_VALUE {
        return march(ijk, v, far.xyz, max(far.w - t, 0.0), l0);
    }
    let exit = textureLoad(bound_t, px, 0);
    if exit.x > 0.5 * NO_VALUE {
        let gap = max(exit.x - t, 0.0);
        let x = min(gap, len);
        return march(ijk, v, mix(ijk, exit.yzw, x / max(gap, 1e-30)), x, l0);
    }
    return march(ijk, v, ijk, 0.5 * len, l0);
}

@fragment
fn fs_pre(in: VsOut) -> PreOut {
    let disp = vec3<f32>(in.world.xy, in.world.z * rp.z_scale);
    var ray = rp.view_dir.xyz;
    if rp.perspective == 1u {
        ray = normalize(disp - rp.eye.xyz);
    }
    let cosv = view_cos(ray);
    let k = view_cos(rp.view_dir.xyz) / cosv;
    // The ray's length through one slab (display units) and the value's
    // derivative along the ray (the gradient is per local unit).
    let len = rp.slab / cosv;
    let slope = dot(in.normal, vec3<f32>(ray.xy, ray.z / rp.z_scale));
    let t = ray_t(disp);
    let px = vec2<i32>(floor(in.clip.xy));
    let far = textureLoad(scalars, px, 0);
    var acc = vec4<f32>(0.0);
    if rp.field_mode != 0u {
        var o: PreOut;
        o.color = pre_ijk(in.normal, in.value, t, far, px, len);
        o.slice = vec4<f32>(in.normal, t);
        o.nearest = o.slice;
        return o;
    }
    if far.x > 0.5 * NO_VALUE {
        let h = 1.0 / f32(SUB_SLABS);
        var f = in.value;
        for (var i = 1u; i <= SUB_SLABS; i++) {
            let b = hermite(in.value, slope * len, far.x, far.y * len, f32(i) * h);
            acc = under(acc, sub_slab(f, b, k));
            f = b;
        }
    } else {
        let exit = textureLoad(bound_t, px, 0).x;
        var x = 0.5 * len;
        if exit > 0.5 * NO_VALUE {
            x = clamp(exit - t, 0.0, len);
        }
        acc = segment(in.value, slope, x, len / f32(SUB_SLABS), k);
    }
    var o: PreOut;
    o.color = acc;
    o.slice = vec4<f32>(in.value, slope, t, 1.0);
    o.nearest = o.slice;
    return o;
}

// The grid's outer surface: its ray distance (the depth test keeps the
// nearest or the farthest).
@vertex
fn vs_boundary(@location(0) pos: vec3<f32>, @location(2) ijk: vec3<f32>) -> VsOut {
    return vertex_out(pos, 0.0, ijk);
}

@fragment
fn fs_boundary(in: VsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(ray_t(vec3<f32>(in.world.xy, in.world.z * rp.z_scale)), in.normal);
}

// A full-screen triangle.
@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(2.0 * x - 1.0, 2.0 * y - 1.0, 0.0, 1.0);
}

// The segment in front of the nearest slice, from where the ray enters the
// grid (half a slab when unknown), extrapolated back along the slice's
// derivative, over the image (the ray taken along view_dir).
@fragment
fn fs_front(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let px = vec2<i32>(floor(p.xy));
    let s = textureLoad(scalars, px, 0);
    if s.x <= 0.5 * NO_VALUE {
        // No slice on this ray: on IJK grids, the whole ray from entry to
        // exit (rays grazing the grid between two slices).
        let e = textureLoad(bound_t, px, 0);
        let x = textureLoad(other_bound_t, px, 0);
        if rp.field_mode == 0u || e.x <= 0.5 * NO_VALUE || x.x <= e.x {
            return vec4<f32>(0.0);
        }
        let len = rp.slab / view_cos(rp.view_dir.xyz);
        return march(e.yzw, field_point(e.yzw), x.yzw, x.x - e.x, len / f32(SUB_SLABS));
    }
    let len = rp.slab / view_cos(rp.view_dir.xyz);
    if rp.field_mode != 0u {
        let e = textureLoad(bound_t, px, 0);
        if e.x <= 0.5 * NO_VALUE {
            return march(s.xyz, field_point(s.xyz), s.xyz, 0.5 * len, len / f32(SUB_SLABS));
        }
        let gap = max(s.w - e.x, 0.0);
        let x = min(gap, len);
        let a = mix(s.xyz, e.yzw, x / max(gap, 1e-30));
        return march(a, field_point(a), s.xyz, x, len / f32(SUB_SLABS));
    }
    let entry = textureLoad(bound_t, px, 0).x;
    var x = 0.5 * len;
    if entry > 0.5 * NO_VALUE {
        x = clamp(s.z - entry, 0.0, len);
    }
    return segment(s.x - s.y * x, s.y, x, len / f32(SUB_SLABS), 1.0);
}
