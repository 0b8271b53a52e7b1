//! The documented limits on what one request may ask for, shared by every
//! front end (the CLI and Python check the same numbers through the same
//! functions): worker threads, levels per run, render slices and
//! isovalues, image sides, scripted frames and benchmark repeats. Each
//! check returns a [`LimitError`] that names the argument in neutral words
//! ("threads", "count", ...) and the limit; a front end may name the
//! argument its own way ([`LimitError::named`]).
//!
//! The limits keep one request within seconds to minutes and within
//! memory on an ordinary machine: beyond them the work only repeats itself
//! (more slices than pixels) or runs for hours before producing anything.

use std::fmt;

use thiserror::Error;

/// Most levels one slicing run sweeps (a level count, or explicit values).
/// Measured: 100 000 levels of an 8-cell grid take 0.6 s and 200 MB
/// (per-level statistics); 1 000 000 take 4.8 s and 1.9 GB.
pub const MAX_LEVELS: usize = 100_000;

/// Most slices of one volume render: more than an image has pixels along
/// any side only repeats work.
pub const MAX_RENDER_SLICES: usize = 8192;

/// Most isovalues of one isosurface render (each is one swept level drawn
/// as a surface; as many as render slices).
pub const MAX_ISOVALUES: usize = MAX_RENDER_SLICES;

/// Largest image side (wgpu's default 2D texture limit).
pub const MAX_IMAGE_SIDE: u32 = 8192;

/// Most frames of one scripted viewer run or orbit benchmark (at 10 ms a
/// frame, under two minutes).
pub const MAX_FRAMES: u64 = 10_000;

/// Most repeats of one benchmark measurement (the best is kept).
pub const MAX_REPEATS: u64 = 1000;

/// Most worker threads: 8 per core, and at least 64. Each thread costs a
/// stack and a spatial block; a million of them took more than a minute on
/// an 8-cell grid, and 100 000 hung a Python session, before this limit.
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (8 * cores).max(64)
}

/// The argument a limit applies to, in neutral words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arg {
    /// The number of worker threads.
    Threads,
    /// The number of evenly spaced levels.
    Count,
    /// Explicit level values.
    Values,
    /// Render slices.
    Slices,
    /// Isovalues of an isosurface render.
    Isovalues,
    /// An image side.
    Size,
    /// Scripted frames.
    Frames,
    /// Benchmark repeats.
    Repeats,
}

impl Arg {
    /// The argument's neutral name (Python's keyword of the same meaning).
    pub fn name(self) -> &'static str {
        match self {
            Arg::Threads => "threads",
            Arg::Count => "count",
            Arg::Values => "values",
            Arg::Slices => "slices",
            Arg::Isovalues => "iso",
            Arg::Size => "size",
            Arg::Frames => "frames",
            Arg::Repeats => "repeat",
        }
    }

    /// What the limit counts, for the message.
    fn unit(self) -> &'static str {
        match self {
            Arg::Threads => "worker threads (8 per core on this machine, at least 64)",
            Arg::Count | Arg::Values => "levels per run",
            Arg::Slices => "slices per render",
            Arg::Isovalues => "isovalues per render",
            Arg::Size => "pixels per image side",
            Arg::Frames => "frames per run",
            Arg::Repeats => "repeats per measurement",
        }
    }
}

impl fmt::Display for Arg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An argument outside its limits: `value` (as given) is not in
/// `min..=max`.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
#[error("{}", self.named(self.arg.name()))]
pub struct LimitError {
    /// The argument.
    pub arg: Arg,
    /// The value given (or the count it gives), as text.
    pub value: String,
    /// The smallest allowed value.
    pub min: u64,
    /// The largest allowed value.
    pub max: u64,
}

impl LimitError {
    /// The message with the argument called `name` (a front end's own
    /// spelling, e.g. a command-line flag).
    pub fn named(&self, name: &str) -> String {
        let LimitError {
            arg,
            value,
            min,
            max,
        } = self;
        let unit = arg.unit();
        if value.parse::<f64>().is_ok_and(|v| v < *min as f64) {
            return format!("{name} must be at least {min} (got {value})");
        }
        match arg {
            Arg::Values => format!(
                "{name} gives {value} levels, more than the limit of {max} {unit}: take fewer levels (a larger step)"
            ),
            Arg::Slices | Arg::Size => {
                format!("{name} {value} is outside {min}..={max} (the limit of {unit})")
            }
            _ => format!("{name} {value} is more than the limit of {max} {unit}"),
        }
    }
}

/// Checks `value` of `arg` against `min..=max`.
fn within(arg: Arg, value: u128, min: u64, max: u64) -> Result<(), LimitError> {
    if value < min as u128 || value > max as u128 {
        return Err(LimitError {
            arg,
            value: value.to_string(),
            min,
            max,
        });
    }
    Ok(())
}

/// Refuses 0 or more than [`max_threads`] threads (any integer width:
/// Python passes what the user typed).
pub fn check_threads(n: impl TryInto<i128>) -> Result<usize, LimitError> {
    count_in(Arg::Threads, wide(n), 1, max_threads() as u64)
}

/// Refuses a level count of 0 or over [`MAX_LEVELS`].
pub fn check_count(k: impl TryInto<i128>) -> Result<usize, LimitError> {
    count_in(Arg::Count, wide(k), 1, MAX_LEVELS as u64)
}

/// Refuses more than [`MAX_LEVELS`] explicit level values (`n` may be a
/// count not yet made, e.g. of a `from:to:step` range: infinite or NaN
/// when it does not fit an f64). An empty list is the pipeline's to refuse,
/// with its own message.
pub fn check_values(n: f64) -> Result<(), LimitError> {
    if n.is_nan() || n > MAX_LEVELS as f64 {
        return Err(LimitError {
            arg: Arg::Values,
            value: if n.is_finite() {
                format!("{n:.0}")
            } else {
                "too many".into()
            },
            min: 1,
            max: MAX_LEVELS as u64,
        });
    }
    Ok(())
}

/// Refuses 0 or more than [`MAX_RENDER_SLICES`] render slices.
pub fn check_slices(n: impl TryInto<i128>) -> Result<usize, LimitError> {
    count_in(Arg::Slices, wide(n), 1, MAX_RENDER_SLICES as u64)
}

/// Refuses more than [`MAX_ISOVALUES`] isovalues (none is the caller's
/// to refuse: it depends on the mode).
pub fn check_isovalues(n: usize) -> Result<(), LimitError> {
    within(Arg::Isovalues, n as u128, 0, MAX_ISOVALUES as u64)
}

/// Refuses an image side of 0 or over [`MAX_IMAGE_SIDE`].
pub fn check_image_side(n: impl TryInto<i128>) -> Result<u32, LimitError> {
    count_in(Arg::Size, wide(n), 1, MAX_IMAGE_SIDE as u64).map(|v| v as u32)
}

/// Refuses 0 or more than [`MAX_FRAMES`] scripted frames.
pub fn check_frames(n: impl TryInto<i128>) -> Result<usize, LimitError> {
    count_in(Arg::Frames, wide(n), 1, MAX_FRAMES)
}

/// Refuses 0 or more than [`MAX_REPEATS`] benchmark repeats.
pub fn check_repeats(n: impl TryInto<i128>) -> Result<usize, LimitError> {
    count_in(Arg::Repeats, wide(n), 1, MAX_REPEATS)
}

/// Any integer as an i128 (a u128 beyond it is over every limit anyway).
fn wide(n: impl TryInto<i128>) -> i128 {
    n.try_into().unwrap_or(i128::MAX)
}

/// `n` as a count in `min..=max`, else the error of `arg`.
fn count_in(arg: Arg, n: i128, min: u64, max: u64) -> Result<usize, LimitError> {
    if n < min as i128 || n > max as i128 {
        return Err(LimitError {
            arg,
            value: n.to_string(),
            min,
            max,
        });
    }
    Ok(n as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_check_names_its_argument_and_limit() {
        let e = check_threads(100_000u64).unwrap_err();
        let m = e.to_string();
        assert!(m.starts_with("threads 100000"), "{m}");
        assert!(m.contains(&max_threads().to_string()), "{m}");
        assert_eq!(check_threads(0).unwrap_err().arg, Arg::Threads);
        assert_eq!(
            check_threads(-1).unwrap_err().to_string(),
            "threads must be at least 1 (got -1)"
        );
        assert_eq!(check_threads(1).unwrap(), 1);
        assert!(
            check_count(10i64.pow(12))
                .unwrap_err()
                .to_string()
                .contains("100000")
        );
        assert_eq!(check_count(MAX_LEVELS as u64).unwrap(), MAX_LEVELS);
        assert!(
            check_values(f64::INFINITY)
                .unwrap_err()
                .to_string()
                .contains("too many")
        );
        assert!(check_values(1e5).is_ok());
        assert!(
            check_slices(10u32.pow(6))
                .unwrap_err()
                .to_string()
                .contains("8192")
        );
        assert!(check_isovalues(MAX_ISOVALUES + 1).is_err());
        assert!(check_image_side(0).is_err() && check_image_side(8193).is_err());
        assert!(check_frames(u32::MAX).is_err() && check_frames(1).is_ok());
        let e = check_repeats(0).unwrap_err();
        assert_eq!(e.named("--repeat"), "--repeat must be at least 1 (got 0)");
    }

    #[test]
    fn messages_do_not_name_command_line_flags() {
        let errs = [
            check_threads(0).unwrap_err(),
            check_count(0).unwrap_err(),
            check_values(f64::NAN).unwrap_err(),
            check_slices(0).unwrap_err(),
            check_image_side(0).unwrap_err(),
            check_frames(0).unwrap_err(),
            check_repeats(10_000).unwrap_err(),
        ];
        for e in errs {
            assert!(!e.to_string().contains("--"), "{e}");
        }
    }
}
