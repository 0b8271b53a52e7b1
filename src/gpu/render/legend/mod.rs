//! The colour legend of rendered images (property, value range, transfer
//! function), painted on the CPU into the [`Image`] (`render --legend`,
//! Python's `legend=True`, both through [`legend_onto`]): a card in the
//! bottom-right corner with the title, a colour bar over an opacity strip
//! and the range's ends and middle. One point is one pixel.
//!
//! The viewer's window paints the same layout with egui (the CLI's
//! `view::overlay`), sharing [`Legend`], [`CARD`] and [`fmt_value`]. The
//! shapes are in [`canvas`], the text (egui's default font, hinted as
//! egui hints it) in [`text`].

pub mod canvas;
mod card;
pub mod text;

pub use card::{
    BAR_STEPS, CARD, Legend, MARGIN, bar_rect, card_rect, fmt_value, legend_onto, paint,
};
