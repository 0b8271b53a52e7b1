// Front pass (after shared/pre.wgsl), after the slab passes: the
// half slab in front of the nearest slice.

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
