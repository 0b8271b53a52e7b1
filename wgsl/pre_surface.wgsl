// Outer-surface pass (after shared/pre.wgsl), before the slab passes:
// the grid's outer surface: its ray distance (the depth test keeps the
// nearest or the farthest).
@vertex
fn vs_boundary(@location(0) pos: vec3<f32>, @location(2) ijk: vec3<f32>) -> VsOut {
    return vertex_out(pos, 0.0, ijk);
}

@fragment
fn fs_boundary(in: VsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(ray_t(vec3<f32>(in.world.xy, in.world.z * rp.z_scale)), in.normal);
}
