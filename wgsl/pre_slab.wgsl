// Pre-integrated slab pass (after shared/pre.wgsl,
// `gpu::render::preintegrated::pass`): one pass per slice, far
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

struct PreOut {
    @location(0) color: vec4<f32>,
    @location(1) slice: vec4<f32>,
    @location(2) nearest: vec4<f32>,
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
