//! The legend's few shapes on the CPU: pixel rectangles, an anti-aliased
//! rounded card and its inner stroke, each blended ("over") into the
//! premultiplied pixels of an [`Image`] and clipped to one rectangle.
//!
//! Colours are straight RGBA in 0..=1, in the image's own (display)
//! encoding, as egui's painter blends into an 8-bit target.

use crate::gpu::render::Image;

/// A straight RGBA colour, 0..=1.
pub type Rgba = [f32; 4];

/// An opaque grey of `v` (0..=255), as egui's `Color32::from_gray`.
pub fn gray(v: u8) -> Rgba {
    let g = f32::from(v) / 255.0;
    [g, g, g, 1.0]
}

/// A rectangle in pixels (x right, y down), edges between pixels at whole numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Left edge.
    pub x0: f32,
    /// Top edge.
    pub y0: f32,
    /// Right edge.
    pub x1: f32,
    /// Bottom edge.
    pub y1: f32,
}

impl Rect {
    /// The rectangle from its left-top to its right-bottom edges.
    pub fn new(x0: f32, y0: f32, x1: f32, y1: f32) -> Self {
        Rect { x0, y0, x1, y1 }
    }

    /// Its width.
    pub fn width(&self) -> f32 {
        self.x1 - self.x0
    }

    /// Whether the pixel (x, y) (its centre) lies inside.
    pub fn contains_pixel(&self, x: i64, y: i64) -> bool {
        let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
        cx > self.x0 && cx < self.x1 && cy > self.y0 && cy < self.y1
    }

    /// The coverage of the pixel (x, y) by this rectangle with corners of
    /// `radius`: its signed distance at the pixel's centre, one pixel of
    /// anti-aliasing across the edge (whole-number edges stay crisp).
    fn rounded_coverage(&self, radius: f32, x: i64, y: i64) -> f32 {
        let r = radius
            .min(0.5 * self.width())
            .min(0.5 * (self.y1 - self.y0));
        let q = |p: f32, lo: f32, hi: f32| (p - 0.5 * (lo + hi)).abs() - (0.5 * (hi - lo) - r);
        let qx = q(x as f32 + 0.5, self.x0, self.x1);
        let qy = q(y as f32 + 0.5, self.y0, self.y1);
        let d = qx.max(0.0).hypot(qy.max(0.0)) + qx.max(qy).min(0.0) - r;
        (0.5 - d).clamp(0.0, 1.0)
    }
}

/// Paints into `img`, only inside `clip` (and the image).
pub struct Canvas<'a> {
    img: &'a mut Image,
    /// Pixel columns `x0..x1` and rows `y0..y1` that may change.
    bounds: [i64; 4],
}

impl<'a> Canvas<'a> {
    /// A canvas on `img` that paints only the pixels whose centres lie in `clip`.
    pub fn new(img: &'a mut Image, clip: Rect) -> Self {
        let (w, h) = (i64::from(img.width), i64::from(img.height));
        let lo = |v: f32, max: i64| (v.round() as i64).clamp(0, max);
        let bounds = [
            lo(clip.x0, w),
            lo(clip.y0, h),
            lo(clip.x1, w),
            lo(clip.y1, h),
        ];
        Canvas { img, bounds }
    }

    /// Blends `c` at `cover` (0..=1) of its alpha over the pixel (x, y).
    pub fn blend(&mut self, x: i64, y: i64, c: Rgba, cover: f32) {
        let [x0, y0, x1, y1] = self.bounds;
        let a = c[3] * cover.clamp(0.0, 1.0);
        if a <= 0.0 || x < x0 || x >= x1 || y < y0 || y >= y1 {
            return;
        }
        let p = &mut self.img.premultiplied[(y * i64::from(self.img.width) + x) as usize];
        for i in 0..3 {
            p[i] = c[i] * a + p[i] * (1.0 - a);
        }
        p[3] = a + p[3] * (1.0 - a);
    }

    /// Fills the pixel columns `x0..x1` of rows `y0..y1` with `c`.
    pub fn fill_pixels(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: Rgba) {
        for y in y0..y1 {
            for x in x0..x1 {
                self.blend(x, y, c, 1.0);
            }
        }
    }

    /// Fills `r` (its corners rounded by `radius`) with `c`, anti-aliased.
    pub fn fill_rounded(&mut self, r: Rect, radius: f32, c: Rgba) {
        self.each_pixel_near(r, |x, y| r.rounded_coverage(radius, x, y), c);
    }

    /// Strokes the inside of `r` (corners rounded by `radius`) with a line
    /// `width` pixels wide in `c`, anti-aliased.
    pub fn stroke_rounded_inside(&mut self, r: Rect, radius: f32, width: f32, c: Rgba) {
        let inner = Rect::new(r.x0 + width, r.y0 + width, r.x1 - width, r.y1 - width);
        let inner_radius = (radius - width).max(0.0);
        self.each_pixel_near(
            r,
            |x, y| r.rounded_coverage(radius, x, y) - inner.rounded_coverage(inner_radius, x, y),
            c,
        );
    }

    /// Frames `r` from outside with a line `width` whole pixels wide in `c`
    /// (`r`'s edges on whole pixels).
    pub fn frame_outside(&mut self, r: Rect, width: i64, c: Rgba) {
        let [x0, y0, x1, y1] = [r.x0, r.y0, r.x1, r.y1].map(|v| v.round() as i64);
        self.fill_pixels(x0 - width, y0 - width, x1 + width, y0, c);
        self.fill_pixels(x0 - width, y1, x1 + width, y1 + width, c);
        self.fill_pixels(x0 - width, y0, x0, y1, c);
        self.fill_pixels(x1, y0, x1 + width, y1, c);
    }

    /// Blends `c` at `cover(x, y)` over every pixel that `r` touches.
    fn each_pixel_near(&mut self, r: Rect, cover: impl Fn(i64, i64) -> f32, c: Rgba) {
        let (x0, y0) = (r.x0.floor() as i64, r.y0.floor() as i64);
        let (x1, y1) = (r.x1.ceil() as i64, r.y1.ceil() as i64);
        for y in y0..y1 {
            for x in x0..x1 {
                self.blend(x, y, c, cover(x, y));
            }
        }
    }
}
