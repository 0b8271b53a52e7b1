//! One line of text on the CPU in egui's default proportional font
//! (Ubuntu Light, from `epaint_default_fonts`): glyph outlines hinted as
//! egui hints them (`skrifa`, smooth vertical hinting, linear advances),
//! rasterized to anti-aliased coverage (`ab_glyph_rasterizer`) at their
//! sub-pixel positions, the baseline on a whole pixel.

use ab_glyph_rasterizer::{Point, Rasterizer, point};
use skrifa::instance::{LocationRef, Size};
use skrifa::outline::{
    DrawSettings, HintingInstance, OutlineGlyphCollection, OutlinePen, SmoothMode, Target,
};
use skrifa::{FontRef, GlyphId, MetadataProvider};

use super::canvas::{Canvas, Rgba};

/// The font: egui's default for proportional text.
const FONT: &[u8] = epaint_default_fonts::UBUNTU_LIGHT;

/// A line of text laid out at one size.
pub struct Line {
    /// Glyphs and their pen positions (pixels from the line's left edge).
    glyphs: Vec<(GlyphId, f32)>,
    /// Sum of the advances, pixels.
    pub width: f32,
    /// Baseline below the line's top edge, whole pixels.
    pub ascent: f32,
    /// Font size, pixels.
    size: f32,
}

/// Lays `text` out at `size` pixels (one row: line breaks are spaces).
/// `None` when the font cannot be read, which the tests rule out.
pub fn layout(text: &str, size: f32) -> Option<Line> {
    let font = FontRef::new(FONT).ok()?;
    let charmap = font.charmap();
    let advances = font.glyph_metrics(Size::new(size), LocationRef::default());
    let mut glyphs = Vec::with_capacity(text.len());
    let mut x = 0.0;
    for ch in text.chars() {
        let ch = if ch.is_control() { ' ' } else { ch };
        let id = charmap.map(ch).unwrap_or(GlyphId::NOTDEF);
        glyphs.push((id, x));
        x += advances.advance_width(id).unwrap_or(0.0);
    }
    // egui's row: ascent, descent and gap rounded to 1/32 point, glyphs
    // aligned to the bottom of the row rounded to whole pixels.
    let m = font.metrics(Size::new(size), LocationRef::default());
    let r32 = |v: f32| (v * 32.0).round() / 32.0;
    let row = r32(m.ascent) - r32(m.descent) + r32(m.leading);
    Some(Line {
        glyphs,
        width: x,
        ascent: (r32(m.ascent) + row.round() - row).round(),
        size,
    })
}

/// Draws `line` with its top-left corner at pixel (x, y) in `c`.
pub fn draw(canvas: &mut Canvas, line: &Line, x: i64, y: i64, c: Rgba) {
    let Ok(font) = FontRef::new(FONT) else {
        return;
    };
    let outlines = font.outline_glyphs();
    // egui's default target: smooth, symmetric, linear metrics.
    let target = Target::Smooth {
        mode: SmoothMode::Normal,
        symmetric_rendering: true,
        preserve_linear_metrics: true,
    };
    let size = Size::new(line.size);
    let hinting = HintingInstance::new(&outlines, size, LocationRef::default(), target).ok();
    let baseline = y + line.ascent as i64;
    for &(id, pen_x) in &line.glyphs {
        // Quarter-pixel positions, as egui's glyph atlas bins them.
        let pen_x = (pen_x * 4.0).round() / 4.0;
        let whole = pen_x.floor();
        let Some(path) = outline(&outlines, hinting.as_ref(), size, id, pen_x - whole) else {
            continue;
        };
        let x = x + whole as i64;
        path.rasterize(|px, py, cover| canvas.blend(x + px, baseline + py, c, alpha(cover)));
    }
}

/// Text alpha from coverage, `2c - c²`: the transfer egui's default
/// (dark) style applies to its glyph atlas, which the egui legend had.
fn alpha(cover: f32) -> f32 {
    let c = cover.clamp(0.0, 1.0);
    2.0 * c - c * c
}

/// The outline of glyph `id` at `size`, hinted when possible, shifted
/// right by `dx` pixels, y down from the baseline.
fn outline(
    outlines: &OutlineGlyphCollection,
    hinting: Option<&HintingInstance>,
    size: Size,
    id: GlyphId,
    dx: f32,
) -> Option<Path> {
    let glyph = outlines.get(id)?;
    let mut path = Path {
        dx,
        ..Path::default()
    };
    let hinted = hinting.is_some_and(|h| {
        glyph
            .draw(DrawSettings::hinted(h, false), &mut path)
            .is_ok()
    });
    if !hinted {
        path = Path {
            dx,
            ..Path::default()
        };
        glyph
            .draw(
                DrawSettings::unhinted(size, LocationRef::default()),
                &mut path,
            )
            .ok()?;
    }
    path.close();
    (!path.segments.is_empty()).then_some(path)
}

/// A segment of an outline: a line, a quadratic or a cubic curve.
enum Segment {
    Line(Point, Point),
    Quad(Point, Point, Point),
    Cubic(Point, Point, Point, Point),
}

/// A glyph's outline in pixels, collected from `skrifa`.
#[derive(Default)]
struct Path {
    segments: Vec<Segment>,
    /// Horizontal shift, pixels.
    dx: f32,
    start: Option<Point>,
    last: Option<Point>,
}

impl Path {
    fn at(&self, x: f32, y: f32) -> Point {
        point(x + self.dx, -y)
    }

    fn push(&mut self, s: Segment, to: Point) {
        self.segments.push(s);
        self.last = Some(to);
    }

    /// Calls `f(x, y, coverage)` for the pixels the outline covers,
    /// (x, y) relative to the glyph's origin (pen position, baseline).
    fn rasterize(&self, mut f: impl FnMut(i64, i64, f32)) {
        let (mut lo, mut hi) = (point(f32::MAX, f32::MAX), point(f32::MIN, f32::MIN));
        for s in &self.segments {
            let pts: &[Point] = match s {
                Segment::Line(a, b) => &[*a, *b],
                Segment::Quad(a, b, c) => &[*a, *b, *c],
                Segment::Cubic(a, b, c, d) => &[*a, *b, *c, *d],
            };
            for p in pts {
                lo = point(lo.x.min(p.x), lo.y.min(p.y));
                hi = point(hi.x.max(p.x), hi.y.max(p.y));
            }
        }
        let (x0, y0) = (lo.x.floor(), lo.y.floor());
        let w = (hi.x.ceil() - x0) as usize;
        let h = (hi.y.ceil() - y0) as usize;
        if w == 0 || h == 0 {
            return;
        }
        let o = |p: &Point| point(p.x - x0, p.y - y0);
        let mut r = Rasterizer::new(w, h);
        for s in &self.segments {
            match s {
                Segment::Line(a, b) => r.draw_line(o(a), o(b)),
                Segment::Quad(a, b, c) => r.draw_quad(o(a), o(b), o(c)),
                Segment::Cubic(a, b, c, d) => r.draw_cubic(o(a), o(b), o(c), o(d)),
            }
        }
        r.for_each_pixel_2d(|x, y, cover| {
            if cover > 0.0 {
                f(x0 as i64 + i64::from(x), y0 as i64 + i64::from(y), cover);
            }
        });
    }
}

impl OutlinePen for Path {
    fn move_to(&mut self, x: f32, y: f32) {
        self.close();
        let p = self.at(x, y);
        self.start = Some(p);
        self.last = Some(p);
    }

    fn line_to(&mut self, x: f32, y: f32) {
        let (from, to) = (self.last.unwrap_or(point(0.0, 0.0)), self.at(x, y));
        self.push(Segment::Line(from, to), to);
    }

    fn quad_to(&mut self, cx0: f32, cy0: f32, x: f32, y: f32) {
        let from = self.last.unwrap_or(point(0.0, 0.0));
        let (c, to) = (self.at(cx0, cy0), self.at(x, y));
        self.push(Segment::Quad(from, c, to), to);
    }

    fn curve_to(&mut self, cx0: f32, cy0: f32, cx1: f32, cy1: f32, x: f32, y: f32) {
        let from = self.last.unwrap_or(point(0.0, 0.0));
        let (c0, c1, to) = (self.at(cx0, cy0), self.at(cx1, cy1), self.at(x, y));
        self.push(Segment::Cubic(from, c0, c1, to), to);
    }

    fn close(&mut self) {
        if let (Some(from), Some(to)) = (self.last, self.start)
            && (from.x != to.x || from.y != to.y)
        {
            self.push(Segment::Line(from, to), to);
        }
        self.start = None;
    }
}
