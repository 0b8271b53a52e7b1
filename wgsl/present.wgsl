// Present pass: the renderer's premultiplied float target composited over
// the background (premultiplied) and written straight (un-premultiplied),
// as `render` writes its PNG. One full-screen triangle; textureLoad (float
// targets need not be filterable).

struct PresentParams {
    background: vec4<f32>,
    // Offset of the scene in the output, in pixels (xy), unused zw.
    offset: vec4<f32>,
}

@group(0) @binding(0) var scene: texture_2d<f32>;
@group(0) @binding(1) var<uniform> pp: PresentParams;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let dims = vec2<i32>(textureDimensions(scene));
    let p = vec2<i32>(floor(pos.xy - pp.offset.xy));
    if any(p < vec2<i32>(0)) || any(p >= dims) {
        return vec4<f32>(pp.background.rgb, 1.0);
    }
    let c = textureLoad(scene, p, 0);
    let o = c + (1.0 - c.a) * pp.background;
    if o.a <= 0.0 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(clamp(o.rgb / o.a, vec3<f32>(0.0), vec3<f32>(1.0)), o.a);
}
