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

// The outline box (`gpu::outline`): lines given in clip space with a
// straight colour, blended over the presented image. Edges the box hides
// itself are drawn as if under the scene: their opacity is scaled by the
// scene's transparency at the pixel (opaque isosurfaces hide them).
struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
}

@vertex
fn vs_line(@location(0) clip: vec4<f32>, @location(1) color: vec4<f32>) -> LineOut {
    var o: LineOut;
    o.clip = clip;
    o.color = color;
    return o;
}

@fragment
fn fs_line_front(in: LineOut) -> @location(0) vec4<f32> {
    return in.color;
}

@fragment
fn fs_line_back(in: LineOut) -> @location(0) vec4<f32> {
    let dims = vec2<i32>(textureDimensions(scene));
    let p = vec2<i32>(floor(in.clip.xy - pp.offset.xy));
    var a = 0.0;
    if all(p >= vec2<i32>(0)) && all(p < dims) {
        a = clamp(textureLoad(scene, p, 0).a, 0.0, 1.0);
    }
    return vec4<f32>(in.color.rgb, in.color.a * (1.0 - a));
}
