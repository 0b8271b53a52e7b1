//! The CPU legend: the card's colours, the bar's steps against the
//! transfer function, the text where it belongs, nothing outside the card.

use super::*;
use crate::gpu::render::legend::canvas::Rect;

/// An opaque image of `rgb` (0..=255).
fn image(w: u32, h: u32, rgb: [u8; 3]) -> Image {
    let c = rgb.map(|v| f32::from(v) / 255.0);
    Image {
        width: w,
        height: h,
        premultiplied: vec![[c[0], c[1], c[2], 1.0]; (w * h) as usize],
    }
}

/// The straight RGBA8 pixel (x, y) of `img`.
fn px(img: &Image, x: f32, y: f32) -> [u8; 4] {
    let i = 4 * (y as usize * img.width as usize + x as usize);
    img.rgba8()[i..i + 4].try_into().unwrap()
}

/// `c` (0..=1) in 8 bits.
fn q(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Paints a legend with `title` on a black 400 × 300 image.
fn painted(title: &str) -> (Image, Image, Transfer) {
    let before = image(400, 300, [0, 0, 0]);
    let mut img = image(400, 300, [0, 0, 0]);
    let transfer = Transfer::named("viridis", -2.0, 6.0).unwrap();
    let l = Legend {
        title,
        range: (-2.0, 6.0),
        transfer: &transfer,
    };
    paint(&mut img, &l);
    (before, img, transfer)
}

#[test]
fn card_sits_in_the_corner_with_its_colours() {
    let (_, img, _) = painted("PORO");
    let card = card_rect(400, 300);
    assert_eq!(card, Rect::new(130.0, 216.0, 390.0, 290.0));
    // The corner pixels lie outside the rounding: untouched.
    for (x, y) in [
        (130.0, 216.0),
        (389.0, 216.0),
        (130.0, 289.0),
        (389.0, 289.0),
    ] {
        assert_eq!(px(&img, x, y), [0, 0, 0, 255], "corner ({x}, {y})");
    }
    // The inner stroke along each edge, grey 120 over the card.
    for (x, y) in [
        (260.0, 216.0),
        (260.0, 289.0),
        (130.0, 250.0),
        (389.0, 250.0),
    ] {
        assert_eq!(px(&img, x, y), [120, 120, 120, 255], "edge ({x}, {y})");
    }
    // On the rounded corner, partly covered: between black and the card.
    let [g, ..] = px(&img, 131.0, 217.0);
    assert!(g > 0 && g < 235, "rounded corner: {g}");
    // The card: white at alpha 235 over black.
    assert_eq!(px(&img, 380.0, 226.0), [235, 235, 235, 255]);
    assert_eq!(px(&img, 380.0, 284.0), [235, 235, 235, 255]);
}

#[test]
fn bar_shows_the_transfer_function_and_its_opacity() {
    let (_, img, t) = painted("PORO");
    let bar = bar_rect(card_rect(400, 300));
    assert_eq!(bar, Rect::new(140.0, 240.0, 380.0, 260.0));
    for i in 0..BAR_STEPS {
        let f = (i as f64 + 0.5) / BAR_STEPS as f64;
        let c = t.eval(-2.0 + 8.0 * f);
        let x = (bar.x0 + bar.width() * f as f32).floor();
        let rgb = |p: [u8; 4]| [p[0], p[1], p[2]];
        assert_eq!(
            rgb(px(&img, x, 242.0)),
            [0, 1, 2].map(|k| q(c[k])),
            "colour of step {i}"
        );
        let a = c[3].clamp(0.0, 1.0);
        let over_white = [0, 1, 2].map(|k| q(c[k].clamp(0.0, 1.0) * a + 1.0 - a));
        assert_eq!(rgb(px(&img, x, 257.0)), over_white, "opacity of step {i}");
    }
    // The 1-px ink frame outside the bar, and the three ticks below it.
    for (x, y) in [
        (139.0, 250.0),
        (380.0, 250.0),
        (200.0, 239.0),
        (200.0, 260.0),
    ] {
        assert_eq!(px(&img, x, y), [20, 20, 20, 255], "frame at ({x}, {y})");
    }
    for x in [140.0, 260.0, 380.0] {
        assert_eq!(px(&img, x, 262.0), [20, 20, 20, 255], "tick at {x}");
        assert_eq!(px(&img, x, 263.0)[0], 235, "tick ends at {x}");
    }
}

#[test]
fn text_lies_in_its_boxes_and_nothing_leaves_the_card() {
    let long = "a very long property name that does not fit on the card at all (m3/m3)";
    for title in ["PORO", long] {
        let (before, img, _) = painted(title);
        let card = card_rect(400, 300);
        let bar = bar_rect(card);
        let (a, b) = (before.rgba8(), img.rgba8());
        let mut title_ink = 0;
        let mut label_ink = 0;
        for y in 0..300_i64 {
            for x in 0..400_i64 {
                let i = 4 * (y * 400 + x) as usize;
                if !card.contains_pixel(x, y) {
                    assert_eq!(
                        a[i..i + 4],
                        b[i..i + 4],
                        "{title}: ({x}, {y}) outside the card"
                    );
                    continue;
                }
                let dark = b[i] < 200;
                let (xf, yf) = (x as f32, y as f32);
                // Away from the rounded edge (dark over the black image).
                let inner = xf >= card.x0 + RADIUS
                    && xf < card.x1 - RADIUS
                    && yf >= card.y0 + RADIUS
                    && yf < card.y1 - RADIUS;
                if dark && inner && yf >= card.y0 + 5.0 && yf < card.y0 + 21.0 {
                    title_ink += 1;
                } else if dark && inner && yf >= bar.y1 + 4.0 {
                    label_ink += 1;
                } else if dark && inner && (yf < bar.y0 - 1.0 || yf > bar.y1 + 3.0) {
                    panic!("{title}: ink at ({x}, {y}) outside the text boxes");
                }
            }
        }
        assert!(
            title_ink > 20,
            "{title}: title drawn ({title_ink} dark pixels)"
        );
        assert!(
            label_ink > 60,
            "{title}: labels drawn ({label_ink} dark pixels)"
        );
    }
}

#[test]
fn text_is_anti_aliased_and_sits_on_its_baseline() {
    let line = text::layout("4.565e5", 11.0).expect("egui's font reads");
    assert!(
        line.width > 30.0 && line.width < 45.0,
        "width {}",
        line.width
    );
    // egui's row for 11 px Ubuntu Light: baseline 11 px below the top.
    assert_eq!(line.ascent, 11.0);
    let mut img = image(60, 20, [255, 255, 255]);
    let mut c = Canvas::new(&mut img, Rect::new(0.0, 0.0, 60.0, 20.0));
    text::draw(&mut c, &line, 2, 2, gray(0));
    let rows: Vec<u32> = (0..20)
        .map(|y| {
            (0..60)
                .map(|x| 255 - u32::from(px(&img, x as f32, y as f32)[0]))
                .sum()
        })
        .collect();
    let inked: Vec<usize> = (0..20).filter(|&y| rows[y] > 0).collect();
    // Digits stand on the baseline (row 2 + 11 = 13 is the first below it).
    assert_eq!(*inked.last().unwrap(), 12, "rows with ink {inked:?}");
    assert!(inked[0] >= 3 && inked[0] <= 5, "cap height: rows {inked:?}");
    let grey = (0..60)
        .flat_map(|x| (0..20).map(move |y| (x, y)))
        .filter(|&(x, y)| (1..255).contains(&px(&img, x as f32, y as f32)[0]))
        .count();
    assert!(grey > 20, "anti-aliased edges: {grey} grey pixels");
}

#[test]
fn long_titles_end_in_an_ellipsis_inside_the_card() {
    let long = "a very long property name that does not fit on the card at all (m3/m3)";
    let cut = elide(long, TITLE_SIZE, CARD[0] - 16.0);
    assert!(cut.ends_with('…') && cut.len() < long.len(), "{cut}");
    assert!(text::layout(&cut, TITLE_SIZE).unwrap().width <= CARD[0] - 16.0);
    assert_eq!(elide("PORO", TITLE_SIZE, CARD[0] - 16.0), "PORO");
    // Nothing of the title in the card's right padding.
    let (_, img, _) = painted(long);
    let card = card_rect(400, 300);
    for y in (card.y0 + 5.0) as i64..(card.y0 + 21.0) as i64 {
        for x in (card.x1 - 8.0) as i64..(card.x1 - 1.0) as i64 {
            assert_eq!(px(&img, x as f32, y as f32)[0], 235, "({x}, {y})");
        }
    }
}

#[test]
fn small_images_are_painted_without_panicking() {
    for (w, h) in [(1, 1), (50, 40), (280, 94)] {
        let mut img = image(w, h, [10, 20, 30]);
        let t = Transfer::named("magma", 0.0, 1.0).unwrap();
        let l = Legend {
            title: "x",
            range: (0.0, 1.0),
            transfer: &t,
        };
        paint(&mut img, &l);
        assert_eq!(img.premultiplied.len(), (w * h) as usize);
    }
}
