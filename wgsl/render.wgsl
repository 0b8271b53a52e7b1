// Render pass: the emitted triangles (OutVertex) drawn with indirect draws.
// Volume mode: transfer-function colour with opacity corrected for the
// slice spacing and the angle between the ray and the slicing axis,
// premultiplied for "over" blending. Slices mode: opacity as is. Iso mode
// (vs_iso): opaque, lit with the field's gradient interpolated along the cut
// edges by the emit pass (a second vertex buffer), then across the triangle.
// Vertical exaggeration: view_proj scales z itself; rays, the eye and
// normals are taken in display space (z × z_scale).

@group(0) @binding(0) var<uniform> rp: RenderParams;
// Transfer function: LUT_SIZE premultiplied-free RGBA entries over
// [value_lo, value_hi], linearly interpolated and clamped.
@group(0) @binding(1) var<storage, read> lut: array<vec4<f32>>;

const LUT_SIZE: u32 = 256u;

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

fn transfer(v: f32) -> vec4<f32> {
    let span = rp.value_hi - rp.value_lo;
    var x = 0.0;
    if span > 0.0 {
        x = clamp((v - rp.value_lo) / span, 0.0, 1.0) * f32(LUT_SIZE - 1u);
    }
    let i = min(u32(floor(x)), LUT_SIZE - 2u);
    let f = x - f32(i);
    return mix(lut[i], lut[i + 1u], f);
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

// Pre-integrated volume mode: the slab behind this slice runs from the
// slice's value (front) to the value one slab further along the ray (back,
// extrapolated with the attribute's gradient, carried in `normal`); its
// colour and opacity come from the table (bilinear), the opacity corrected
// for the ray's angle to the axis.
@fragment
fn fs_pre(in: VsOut) -> @location(0) vec4<f32> {
    let disp = vec3<f32>(in.world.xy, in.world.z * rp.z_scale);
    var ray = rp.view_dir.xyz;
    if rp.perspective == 1u {
        ray = normalize(disp - rp.eye.xyz);
    }
    let cosv = max(abs(dot(ray, rp.axis.xyz)), 1e-3);
    // The ray's step through one slab, back in local (physical) units.
    let step = ray * (rp.slab / cosv);
    let local_step = vec3<f32>(step.xy, step.z / rp.z_scale);
    let back = in.value + dot(in.normal, local_step);
    let xf = pre_coord(in.value);
    let xb = pre_coord(back);
    let f0 = min(u32(floor(xf)), PRE_SIZE - 2u);
    let b0 = min(u32(floor(xb)), PRE_SIZE - 2u);
    let wf = xf - f32(f0);
    let wb = xb - f32(b0);
    let lo = mix(pre_at(f0, b0), pre_at(f0 + 1u, b0), wf);
    let hi = mix(pre_at(f0, b0 + 1u), pre_at(f0 + 1u, b0 + 1u), wf);
    let c = mix(lo, hi, wb);
    let a = clamp(c.a, 0.0, 1.0);
    if a <= 0.0 {
        return vec4<f32>(0.0);
    }
    // Off-axis: the slab is 1/cos thicker.
    let a2 = 1.0 - pow(1.0 - a, 1.0 / cosv);
    return vec4<f32>(c.rgb * (a2 / a), a2);
}
