//! The colour legend (property, value range, transfer function) painted
//! with egui on the GPU: the viewer's window draws it over the scene and
//! [`legend_onto`] into a rendered image (`render --legend`, Python's
//! `legend=True`), with the same painter ([`paint_legend`]).

use egui::{Align2, Color32, FontId, Painter, Rect, Stroke, Vec2, pos2, vec2};

use super::context::{GpuContext, GpuError};
use super::render::{
    Image, Mode, RenderError, RenderOptions, Renderer, Transfer, slice_key, slicing_axis,
    transfer_for,
};
use crate::grid::Grid;

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

/// A number for the legend: 4 significant digits, scientific when large or small.
pub fn fmt_value(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.3e}")
    } else {
        let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.digits$}")
    }
}

/// What the legend shows.
pub struct Legend<'a> {
    /// Property name (with units when known).
    pub title: &'a str,
    /// The shown value range.
    pub range: (f64, f64),
    /// The transfer function (colour and opacity along the range).
    pub transfer: &'a Transfer,
}

/// Size of the legend in points.
pub const LEGEND_SIZE: Vec2 = vec2(260.0, 74.0);

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

/// The legend painted (egui, on the GPU) into the bottom-right corner of
/// `img`, which `r` rendered from `grid` with `o` (the range is its
/// slices'): `render --legend`, Python's `legend=True`.
pub fn legend_onto(
    r: &Renderer,
    grid: &Grid,
    o: &RenderOptions,
    img: Image,
) -> Result<Image, RenderError> {
    let ctx = r.ctx();
    let d = glam::Vec3::from_array(o.view_dir.map(|c| c as f32)).normalize();
    let mut k = slice_key(grid, o, slicing_axis(d))?;
    if r.preintegrated() && o.mode == Mode::Volume {
        k = k.with_attr_gradient();
    }
    let set = r
        .slices(&k.key)
        .ok_or_else(|| RenderError::Options("the legend needs the rendered slices".into()))?;
    let transfer = transfer_for(o, set.range)?;
    let title = k
        .property
        .clone()
        .unwrap_or_else(|| "(slice position)".into());
    let (w, h) = (img.width, img.height);
    let format = wgpu::TextureFormat::Rgba8Unorm;
    let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("legend"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let extent = tex.size();
    ctx.queue.write_texture(
        tex.as_image_copy(),
        &img.rgba8(),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(4 * w),
            rows_per_image: Some(h),
        },
        extent,
    );
    let view = tex.create_view(&Default::default());
    let mut overlay = Overlay::new(ctx, format);
    let input = egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(
            egui::Pos2::ZERO,
            egui::vec2(w as f32, h as f32),
        )),
        ..Default::default()
    };
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    let legend = Legend {
        title: &title,
        range: set.range,
        transfer: &transfer,
    };
    overlay.paint(ctx, &mut enc, &view, (w, h), input, |ectx| {
        let screen = ectx.content_rect();
        let rect = egui::Align2::RIGHT_BOTTOM
            .anchor_size(screen.max - egui::vec2(10.0, 10.0), LEGEND_SIZE);
        paint_legend(
            &ectx.layer_painter(egui::LayerId::background()),
            rect,
            &legend,
        );
    });
    ctx.queue.submit([enc.finish()]);
    let bytes = read_rgba8(ctx, &tex)?;
    let mut px = Vec::with_capacity((w * h) as usize);
    for y in 0..h as usize {
        for x in 0..w as usize {
            let o = (y * w as usize + x) * 4;
            let a = bytes[o + 3] as f32 / 255.0;
            px.push(std::array::from_fn(|i| {
                if i == 3 {
                    a
                } else {
                    bytes[o + i] as f32 / 255.0 * a
                }
            }));
        }
    }
    Ok(Image {
        width: w,
        height: h,
        premultiplied: px,
    })
}

/// Reads an 8-bit RGBA or BGRA texture back as straight RGBA bytes, rows top to bottom.
pub fn read_rgba8(ctx: &GpuContext, tex: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
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
