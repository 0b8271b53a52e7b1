//! The policy layer: every decision about a request made once, for every
//! front end (in the way ripgrep's `HiArgs` turns raw flags into one
//! resolved plan). A front end parses its own syntax (the CLI's flags,
//! Python's keywords) into a plain-data request ([`render::RenderRequest`],
//! [`device::Device`]); the policy validates it into a plan or refuses it
//! with a [`PolicyError`] whose text names the options by neutral
//! [`Opt`]s, which each front end spells its own way ([`Spelling`]): the
//! CLI as `--z-scale 2`, Python as `z_scale=2`.
//!
//! What lives here: the render options and their defaults (image size
//! limits, background, mode and isovalues, the default vertical
//! exaggeration, how cut cells are found), transfer functions from a
//! colormap name, a JSON file or JSON text ([`transfer`]), the checks
//! against blank images and isovalues outside the data, the shown
//! property, and where slicing and rendering run ([`device`]). Nothing
//! here reads environment variables or knows a front end's syntax.

pub mod device;
mod message;
pub mod render;
pub mod transfer;

pub(crate) use message::limit;
pub use message::{Message, Neutral, Opt, PolicyError, Refusal, Spelling, Value};
