//! The legend card: its layout, painted into an [`Image`]
//! ([`paint`]) and onto a rendered image ([`legend_onto`]).

use super::canvas::{Canvas, Rect, Rgba, gray};
use super::text;

use crate::gpu::render::camera::slicing_axis;
use crate::gpu::render::options::transfer_for;
use crate::gpu::render::slice_cache::slice_key;
use crate::gpu::render::{Image, Mode, RenderError, RenderOptions, Renderer, Transfer};
use crate::grid::Grid;

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

/// Size of the legend card in points (width, height).
pub const CARD: [f32; 2] = [260.0, 74.0];

/// Distance of the card from the image's right and bottom edges, points.
pub const MARGIN: f32 = 10.0;

/// Steps of the colour bar.
pub const BAR_STEPS: usize = 128;

/// Corner radius of the card, points.
const RADIUS: f32 = 4.0;

/// Title and label sizes, points.
const TITLE_SIZE: f32 = 13.0;
const LABEL_SIZE: f32 = 11.0;

/// The card's rectangle in an image of `width` × `height` pixels.
pub fn card_rect(width: u32, height: u32) -> Rect {
    let (x1, y1) = (width as f32 - MARGIN, height as f32 - MARGIN);
    Rect::new(x1 - CARD[0], y1 - CARD[1], x1, y1)
}

/// The colour bar's rectangle in `card`: its upper half shows the
/// transfer colour, its lower half that colour at its opacity over white.
pub fn bar_rect(card: Rect) -> Rect {
    Rect::new(
        card.x0 + 10.0,
        card.y0 + 24.0,
        card.x1 - 10.0,
        card.y0 + 44.0,
    )
}

/// Paints the legend into the bottom-right corner of `img`: the card
/// (white at alpha 235 with a grey inner stroke), the title, the colour
/// bar and its frame, three ticks and their values. Nothing outside the
/// card changes.
pub fn paint(img: &mut Image, l: &Legend) {
    let card = card_rect(img.width, img.height);
    let mut c = Canvas::new(img, card);
    let ink = gray(20);
    c.fill_rounded(card, RADIUS, [1.0, 1.0, 1.0, 235.0 / 255.0]);
    c.stroke_rounded_inside(card, RADIUS, 1.0, gray(120));
    let title = elide(l.title, TITLE_SIZE, card.width() - 16.0);
    put_text(
        &mut c,
        &title,
        TITLE_SIZE,
        (card.x0 + 8.0, card.y0 + 5.0),
        0.0,
        ink,
    );
    let bar = bar_rect(card);
    let (lo, hi) = l.range;
    let (top, mid, bottom) = (
        bar.y0 as i64,
        (0.5 * (bar.y0 + bar.y1)) as i64,
        bar.y1 as i64,
    );
    let column = |i: usize| (bar.x0 + bar.width() * i as f32 / BAR_STEPS as f32).round() as i64;
    for i in 0..BAR_STEPS {
        let v = lo + (hi - lo) * ((i as f64 + 0.5) / BAR_STEPS as f64);
        let [r, g, b, a] = l.transfer.eval(v).map(|x| x.clamp(0.0, 1.0));
        let (x0, x1) = (column(i), column(i + 1));
        c.fill_pixels(x0, top, x1, mid, q8([r, g, b, 1.0]));
        let over_white = |x: f32| x * a + (1.0 - a);
        c.fill_pixels(
            x0,
            mid,
            x1,
            bottom,
            q8([over_white(r), over_white(g), over_white(b), 1.0]),
        );
    }
    c.frame_outside(bar, 1, ink);
    for (f, anchor) in [(0.0, 0.0), (0.5, 0.5), (1.0, 1.0)] {
        let x = bar.x0 + f * bar.width();
        let col = (x - 0.5).round() as i64;
        c.fill_pixels(col, bottom, col + 1, bottom + 3, ink);
        let v = lo + (hi - lo) * f64::from(f);
        put_text(
            &mut c,
            &fmt_value(v),
            LABEL_SIZE,
            (x, bar.y1 + 4.0),
            anchor,
            ink,
        );
    }
}

/// `c` quantized to 8 bits, as the egui painter's `Color32` held it.
fn q8(c: Rgba) -> Rgba {
    c.map(|x| (x * 255.0).round() / 255.0)
}

/// `s`, cut and ended with an ellipsis when wider than `width` pixels at `size`.
fn elide(s: &str, size: f32, width: f32) -> String {
    let fits = |t: &str| text::layout(t, size).is_none_or(|l| l.width <= width);
    if fits(s) {
        return s.to_owned();
    }
    let mut cut: Vec<char> = s.chars().collect();
    while !cut.is_empty() {
        cut.pop();
        let t: String = cut.iter().collect::<String>().trim_end().to_owned() + "…";
        if fits(&t) {
            return t;
        }
    }
    "…".into()
}

/// Draws `s` at `size` with its top edge at `at.1` and the point `anchor`
/// (0 left, 0.5 centre, 1 right) of its width at `at.0`, on whole pixels.
fn put_text(c: &mut Canvas, s: &str, size: f32, at: (f32, f32), anchor: f32, ink: Rgba) {
    if let Some(line) = text::layout(s, size) {
        let x = (at.0 - anchor * line.width).round() as i64;
        text::draw(c, &line, x, at.1.round() as i64, ink);
    }
}

/// The legend painted into the bottom-right corner of `img`, which `r`
/// rendered from `grid` with `o` (the range is its slices'):
/// `render --legend`, Python's `legend=True`.
pub fn legend_onto(
    r: &Renderer,
    grid: &Grid,
    o: &RenderOptions,
    mut img: Image,
) -> Result<Image, RenderError> {
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
    let legend = Legend {
        title: &title,
        range: set.range,
        transfer: &transfer,
    };
    paint(&mut img, &legend);
    Ok(img)
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
