// Slices pass (after shared/draw.wgsl): the emitted triangles (OutVertex)
// drawn with indirect draws. Volume mode: transfer-function colour with
// opacity corrected for the slice spacing and the angle between the ray and
// the slicing axis, premultiplied for "over" blending. Slices mode: opacity
// as is. Iso mode (vs_iso): opaque, lit with the field's gradient
// interpolated along the cut edges by the emit pass (a second vertex
// buffer), then across the triangle.

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
