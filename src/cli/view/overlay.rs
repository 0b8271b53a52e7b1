//! egui drawn over the scene with egui-wgpu: the viewer's panel, the colour
//! legend and the outline box with its axes. The window's legend is the
//! layout of the library's CPU painter ([`stratasweep::gpu::render::legend`], which
//! draws `render --legend` and Python's `legend=True`) in egui.

use egui::{Align2, Color32, FontId, Painter, Pos2, Rect, Stroke, Vec2, pos2, vec2};
use glam::{Mat4, Vec3};

use stratasweep::gpu::context::GpuContext;
pub use stratasweep::gpu::render::legend::Legend;
use stratasweep::gpu::render::legend::{self, fmt_value};

/// egui's context and its wgpu renderer for one output format.
pub struct Overlay {
    /// The egui context.
    pub egui: egui::Context,
    renderer: egui_wgpu::Renderer,
}

impl Overlay {
    /// An overlay drawing into `format` targets.
    pub fn new(ctx: &GpuContext, format: wgpu::TextureFormat) -> Self {
        Overlay {
            egui: egui::Context::default(),
            renderer: egui_wgpu::Renderer::new(
                &ctx.device,
                format,
                egui_wgpu::RendererOptions {
                    dithering: false,
                    ..Default::default()
                },
            ),
        }
    }

    /// Runs one egui pass with `ui` and records its drawing over `view`
    /// (loaded, not cleared). Returns the platform output (cursor, ...).
    pub fn paint(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        size: (u32, u32),
        input: egui::RawInput,
        ui: impl FnMut(&egui::Context),
    ) -> egui::PlatformOutput {
        let out = self.egui.run_pass(input, ui);
        let ppp = out.pixels_per_point;
        let jobs = self.egui.tessellate(out.shapes, ppp);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [size.0, size.1],
            pixels_per_point: ppp,
        };
        for (id, deltas) in &out.textures_delta.set {
            for delta in deltas {
                self.renderer
                    .update_texture(&ctx.device, &ctx.queue, *id, delta);
            }
        }
        let extra = self
            .renderer
            .update_buffers(&ctx.device, &ctx.queue, enc, &jobs, &screen);
        if !extra.is_empty() {
            ctx.queue.submit(extra);
        }
        {
            let pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            let mut pass = pass.forget_lifetime();
            self.renderer.render(&mut pass, &jobs, &screen);
        }
        for id in &out.textures_delta.free {
            self.renderer.free_texture(id);
        }
        out.platform_output
    }
}

/// Size of the legend in points (the library's card, [`legend::CARD`]).
pub const LEGEND_SIZE: Vec2 = vec2(legend::CARD[0], legend::CARD[1]);

/// Paints the legend in `rect`: a framed card with the title, a colour
/// bar (transfer colour over a checkerboard, shown with its opacity in a
/// second strip) and the range's ends and middle.
pub fn paint_legend(p: &Painter, rect: Rect, l: &Legend) {
    let ink = Color32::from_gray(20);
    p.rect_filled(rect, 4.0, Color32::from_white_alpha(235));
    p.rect_stroke(
        rect,
        4.0,
        Stroke::new(1.0, Color32::from_gray(120)),
        egui::StrokeKind::Inside,
    );
    let font = FontId::proportional(13.0);
    p.text(
        rect.min + vec2(8.0, 5.0),
        Align2::LEFT_TOP,
        l.title,
        font.clone(),
        ink,
    );
    let bar = Rect::from_min_max(
        rect.min + vec2(10.0, 24.0),
        pos2(rect.max.x - 10.0, rect.min.y + 44.0),
    );
    let n = 128;
    let (lo, hi) = l.range;
    for i in 0..n {
        let f0 = i as f32 / n as f32;
        let f1 = (i + 1) as f32 / n as f32;
        let v = lo + (hi - lo) * ((i as f64 + 0.5) / n as f64);
        let c = l.transfer.eval(v);
        let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
        let x0 = bar.min.x + f0 * bar.width();
        let x1 = bar.min.x + f1 * bar.width() + 0.5;
        let top = Rect::from_min_max(pos2(x0, bar.min.y), pos2(x1, bar.center().y));
        p.rect_filled(top, 0.0, Color32::from_rgb(q(c[0]), q(c[1]), q(c[2])));
        // Lower strip: the colour at its opacity over white.
        let a = c[3].clamp(0.0, 1.0);
        let mix = |x: f32| q(x * a + (1.0 - a));
        let bottom = Rect::from_min_max(pos2(x0, bar.center().y), pos2(x1, bar.max.y));
        p.rect_filled(
            bottom,
            0.0,
            Color32::from_rgb(mix(c[0]), mix(c[1]), mix(c[2])),
        );
    }
    p.rect_stroke(bar, 0.0, Stroke::new(1.0, ink), egui::StrokeKind::Outside);
    let small = FontId::proportional(11.0);
    for (f, anchor) in [
        (0.0, Align2::LEFT_TOP),
        (0.5, Align2::CENTER_TOP),
        (1.0, Align2::RIGHT_TOP),
    ] {
        let x = bar.min.x + f * bar.width();
        p.line_segment(
            [pos2(x, bar.max.y), pos2(x, bar.max.y + 3.0)],
            Stroke::new(1.0, ink),
        );
        let v = lo + (hi - lo) * f as f64;
        p.text(
            pos2(x, bar.max.y + 4.0),
            anchor,
            fmt_value(v),
            small.clone(),
            ink,
        );
    }
}

/// Paints the X, Y and Z axes from the lowest corner of the grid's bounding
/// box (display space extents `ext`, centred on the local origin) as seen
/// through `view_proj` (display → clip), in a viewport of `size` points.
/// The box's edges are drawn by the present pass (`gpu::view::outline`), the
/// hidden ones under the scene.
pub fn paint_outline(p: &Painter, view_proj: Mat4, ext: Vec3, size: Vec2) {
    let corner = |i: usize| {
        let s = |b: usize| if i >> b & 1 == 1 { 0.5 } else { -0.5 };
        ext * Vec3::new(s(0), s(1), s(2))
    };
    let project = |q: Vec3| -> Option<Pos2> {
        let c = view_proj * q.extend(1.0);
        (c.w > 1e-6).then(|| {
            pos2(
                (c.x / c.w * 0.5 + 0.5) * size.x,
                (0.5 - c.y / c.w * 0.5) * size.y,
            )
        })
    };
    let o = corner(0);
    let colors = [
        Color32::from_rgb(220, 40, 40),
        Color32::from_rgb(30, 160, 30),
        Color32::from_rgb(40, 70, 230),
    ];
    for (a, name) in ["X", "Y", "Z"].iter().enumerate() {
        let mut e = Vec3::ZERO;
        e[a] = ext[a].max(1e-6) * 0.3;
        if let (Some(s), Some(t)) = (project(o), project(o + e)) {
            p.line_segment([s, t], Stroke::new(2.5, colors[a]));
            p.text(
                t,
                Align2::CENTER_CENTER,
                *name,
                FontId::proportional(14.0),
                colors[a],
            );
        }
    }
}

/// Reads an 8-bit RGBA or BGRA texture back as straight RGBA bytes, rows top to bottom.
pub fn read_rgba8(ctx: &GpuContext, tex: &wgpu::Texture) -> anyhow::Result<Vec<u8>> {
    let (w, h) = (tex.width(), tex.height());
    let bpr = (4 * w).div_ceil(256) * 256;
    let buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read-back"),
        size: bpr as u64 * h as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        tex.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buf,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(bpr),
                rows_per_image: Some(h),
            },
        },
        tex.size(),
    );
    ctx.queue.submit([enc.finish()]);
    let bytes = ctx.read_buffer(&buf, bpr as u64 * h as u64)?;
    let bgra = matches!(
        tex.format(),
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    let mut out = Vec::with_capacity((4 * w * h) as usize);
    for y in 0..h as usize {
        for px in bytes[y * bpr as usize..][..4 * w as usize].chunks_exact(4) {
            if bgra {
                out.extend_from_slice(&[px[2], px[1], px[0], px[3]]);
            } else {
                out.extend_from_slice(px);
            }
        }
    }
    Ok(out)
}
