//! The words of the policy layer: options by their neutral names
//! ([`Opt`]), messages that keep options apart from the words around them
//! ([`Message`]) so that each front end spells them ([`Spelling`]), and
//! [`PolicyError`].

use std::fmt;

use crate::gpu::render::RenderError;
use crate::limits::LimitError;

/// An option of a request, by its neutral name (Python's keyword; the
/// CLI's flag is `--` and the name with `-` for `_`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Opt {
    /// The shown property.
    Property,
    /// Render slices.
    Slices,
    /// The view direction.
    ViewDir,
    /// The up vector.
    Up,
    /// Orthographic or perspective.
    Projection,
    /// Colormap name, transfer-function file or JSON.
    Transfer,
    /// Unit distance of the opacities.
    UnitDistance,
    /// Background colour.
    Background,
    /// Image size.
    Size,
    /// Volume, slices or iso.
    Mode,
    /// Isovalues.
    Iso,
    /// Vertical exaggeration.
    ZScale,
    /// Pre-integrated volume rendering.
    Preintegrated,
    /// How cut cells are found.
    Cells,
    /// The colour legend.
    Legend,
    /// Adapter name.
    Adapter,
    /// Where polygons are generated or images drawn.
    Device,
    /// Whether the sliced polygons are gathered (the CLI: `-o`).
    Mesh,
    /// The sweep structure.
    Structure,
}

impl Opt {
    /// The neutral name (Python's keyword).
    pub fn name(self) -> &'static str {
        match self {
            Opt::Property => "property",
            Opt::Slices => "slices",
            Opt::ViewDir => "view_dir",
            Opt::Up => "up",
            Opt::Projection => "projection",
            Opt::Transfer => "transfer",
            Opt::UnitDistance => "unit_distance",
            Opt::Background => "background",
            Opt::Size => "size",
            Opt::Mode => "mode",
            Opt::Iso => "iso",
            Opt::ZScale => "z_scale",
            Opt::Preintegrated => "preintegrated",
            Opt::Cells => "cells",
            Opt::Legend => "legend",
            Opt::Adapter => "adapter",
            Opt::Device => "device",
            Opt::Mesh => "mesh",
            Opt::Structure => "structure",
        }
    }
}

/// A value an option is set to, inside a message (`mode` set to `iso`).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A word (a mode, a device name).
    Word(&'static str),
    /// On or off.
    Bool(bool),
}

/// How a front end writes an option, alone or set to a value.
pub trait Spelling {
    /// `opt` alone (`--iso`, `iso`) or set to `value` (`--mode iso`,
    /// `mode='iso'`).
    fn spell(&self, opt: Opt, value: Option<&Value>) -> String;
}

/// The neutral spelling: the name alone, or `name=value` as Python writes
/// a keyword argument (`mode='iso'`, `mesh=False`).
pub struct Neutral;

impl Spelling for Neutral {
    fn spell(&self, opt: Opt, value: Option<&Value>) -> String {
        match value {
            None => opt.name().into(),
            Some(Value::Word(w)) => format!("{}='{w}'", opt.name()),
            Some(Value::Bool(b)) => {
                format!("{}={}", opt.name(), if *b { "True" } else { "False" })
            }
        }
    }
}

/// One piece of a message: text, or an option that each front end spells.
#[derive(Clone, Debug, PartialEq)]
enum Piece {
    Text(String),
    Opt(Opt, Option<Value>),
}

/// A message that names options ([`Opt`]) apart from its text.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Message(Vec<Piece>);

impl Message {
    /// An empty message.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds text.
    pub fn text(mut self, t: impl Into<String>) -> Self {
        self.0.push(Piece::Text(t.into()));
        self
    }

    /// Adds an option's name.
    pub fn opt(mut self, o: Opt) -> Self {
        self.0.push(Piece::Opt(o, None));
        self
    }

    /// Adds an option set to a value.
    pub fn opt_is(mut self, o: Opt, v: Value) -> Self {
        self.0.push(Piece::Opt(o, Some(v)));
        self
    }

    /// Whether the message is empty.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The text with options spelled by `s`.
    pub fn spelled(&self, s: &dyn Spelling) -> String {
        self.0
            .iter()
            .map(|p| match p {
                Piece::Text(t) => t.clone(),
                Piece::Opt(o, v) => s.spell(*o, v.as_ref()),
            })
            .collect()
    }
}

impl fmt::Display for Message {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.spelled(&Neutral))
    }
}

/// Why a request was refused.
#[derive(Debug)]
pub enum Refusal {
    /// A bad option or combination of options.
    Invalid(Message),
    /// A file the request names could not be read.
    Read {
        /// What the file is and its path ("the transfer function a.json").
        what: String,
        /// The reason.
        source: std::io::Error,
    },
    /// The renderer's checks refused the options.
    Render(RenderError),
    /// What the request needs is not there (no adapter of the kind asked for).
    Unavailable(Message),
}

/// A refused request: what was refused, under an optional context that
/// names the options concerned.
#[derive(Debug)]
pub struct PolicyError {
    /// The options concerned (empty: none).
    pub context: Message,
    /// What was refused.
    pub refusal: Refusal,
}

impl PolicyError {
    /// A bad option.
    pub fn invalid(m: Message) -> Self {
        PolicyError {
            context: Message::new(),
            refusal: Refusal::Invalid(m),
        }
    }

    /// The same refusal under `context`.
    pub fn context(mut self, context: Message) -> Self {
        self.context = context;
        self
    }

    /// The whole text with options spelled by `s` (`context: refusal`).
    pub fn spelled(&self, s: &dyn Spelling) -> String {
        let body = match &self.refusal {
            Refusal::Invalid(m) | Refusal::Unavailable(m) => m.spelled(s),
            Refusal::Read { what, source } => format!("cannot read {what}: {source}"),
            Refusal::Render(e) => e.to_string(),
        };
        match self.context.is_empty() {
            true => body,
            false => format!("{}: {body}", self.context.spelled(s)),
        }
    }
}

impl fmt::Display for PolicyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.spelled(&Neutral))
    }
}

impl std::error::Error for PolicyError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.refusal {
            Refusal::Read { source, .. } => Some(source),
            Refusal::Render(e) => Some(e),
            Refusal::Invalid(_) | Refusal::Unavailable(_) => None,
        }
    }
}

impl From<RenderError> for PolicyError {
    fn from(e: RenderError) -> Self {
        PolicyError {
            context: Message::new(),
            refusal: Refusal::Render(e),
        }
    }
}

/// A library limit ([`crate::limits`]) as a refusal naming `opt`.
pub(crate) fn limit(opt: Opt) -> impl Fn(LimitError) -> PolicyError {
    move |e| {
        // The limit's message after its own neutral name.
        let rest = e.named("\u{0}");
        let rest = rest.strip_prefix('\u{0}').unwrap_or(&rest).to_string();
        PolicyError::invalid(Message::new().opt(opt).text(rest))
    }
}
