//! The CLI's checks on its arguments, made before any file is read or
//! written: documented limits on levels, threads, render slices and image
//! sizes (each error names the flag and the limit), output extensions, and
//! output paths against input paths (`io::guard`).

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use stratasweep::io::guard::{Named, check_outputs, known_inputs};

/// Most levels one `slice` or `bench` run sweeps (`--count`, `--values`).
/// Measured: 100 000 levels of an 8-cell grid take 0.6 s and 200 MB
/// (per-level statistics); 1 000 000 take 4.8 s and 1.9 GB.
pub const MAX_LEVELS: usize = 100_000;

/// Most slices of one `render` (`--slices`): more than an image has pixels
/// along any side only repeats work.
pub const MAX_RENDER_SLICES: usize = 8192;

/// Largest image side of `render --size` (wgpu's default texture limit).
pub const MAX_IMAGE_SIDE: u32 = 8192;

/// Most worker threads (`--threads`): 8 per core, and at least 64. Each
/// thread costs a stack and a spatial block; a million of them took more
/// than a minute on an 8-cell grid before this limit.
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (8 * cores).max(64)
}

/// Refuses 0 or more than [`max_threads`] threads.
pub fn check_threads(n: usize) -> Result<()> {
    let max = max_threads();
    if n == 0 {
        bail!("--threads must be at least 1");
    }
    if n > max {
        bail!(
            "--threads {n} is more than the limit of {max} (8 per core on this machine, at least 64)"
        );
    }
    Ok(())
}

/// Refuses a level count of 0 or over [`MAX_LEVELS`].
pub fn check_count(k: usize) -> Result<()> {
    if k == 0 {
        bail!("--count must be at least 1");
    }
    if k > MAX_LEVELS {
        bail!("--count {k} is more than the limit of {MAX_LEVELS} levels per run");
    }
    Ok(())
}

/// Parses `--values FROM:TO:STEP`, counting the levels before making them.
pub fn values_levels(s: &str) -> Result<Vec<f64>> {
    let p: Vec<f64> = s
        .split(':')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--values '{s}': expected FROM:TO:STEP (three numbers)"))?;
    if p.len() != 3 || p.iter().any(|x| !x.is_finite()) || p[2] <= 0.0 || p[1] < p[0] {
        bail!("--values '{s}': expected FROM:TO:STEP, finite, with FROM <= TO and STEP > 0");
    }
    let n = stratasweep::field::range_level_count(p[0], p[1], p[2]);
    if n.is_nan() || n > MAX_LEVELS as f64 {
        bail!(
            "--values '{s}' gives {} levels, more than the limit of {MAX_LEVELS} levels per run: take a larger STEP",
            if n.is_finite() {
                format!("{n:.0}")
            } else {
                "too many".into()
            }
        );
    }
    let v = stratasweep::field::levels_by_range(p[0], p[1], p[2]);
    // FROM + k·STEP rounds to the same f64 when STEP is below FROM's ulp.
    if let Some(w) = v.windows(2).find(|w| w[1] <= w[0]) {
        bail!(
            "--values '{s}': STEP is below the precision of the values ({} and {} are the same number)",
            w[0],
            w[1]
        );
    }
    Ok(v)
}

/// Refuses more than [`MAX_RENDER_SLICES`] or zero render slices.
pub fn check_slices(n: usize) -> Result<()> {
    if n == 0 || n > MAX_RENDER_SLICES {
        bail!("--slices {n} is outside 1..={MAX_RENDER_SLICES} (the limit of slices per render)");
    }
    Ok(())
}

/// The lower-case extension of `path`, if it is one of `allowed`, else an
/// error naming the flag and the extensions it writes.
pub fn output_ext(flag: &str, path: &Path, allowed: &[&str]) -> Result<String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext {
        Some(e) if allowed.contains(&e.as_str()) => Ok(e),
        _ => {
            let list = allowed
                .iter()
                .map(|e| format!(".{e}"))
                .collect::<Vec<_>>()
                .join(", ");
            bail!(
                "{flag} {}: cannot write this file type; the extension must be one of {list}",
                path.display()
            )
        }
    }
}

/// The outputs of one command, labelled by their flags.
#[derive(Default)]
pub struct Outputs(pub Vec<Named>);

impl Outputs {
    /// Adds `path` under `flag` when given.
    pub fn add(mut self, flag: &str, path: Option<&Path>) -> Self {
        if let Some(p) = path {
            self.0.push(Named::new(flag, p));
        }
        self
    }

    /// Before anything is read: refuses outputs naming the grid file, the
    /// INIT beside an EGRID, one of `extra` (a transfer function), or each
    /// other.
    pub fn check_before(&self, grid: Option<&Path>, extra: &[Named]) -> Result<()> {
        let mut inputs: Vec<Named> = extra.to_vec();
        if let Some(g) = grid {
            for (i, p) in known_inputs(g).into_iter().enumerate() {
                let label = if i == 0 {
                    "the grid file"
                } else {
                    "the INIT file read with the grid"
                };
                inputs.push(Named::new(label, p));
            }
        }
        Ok(check_outputs(&self.0, &inputs)?)
    }

    /// After the load, before anything is written: refuses outputs naming
    /// any file the load read (INCLUDEs).
    pub fn check_after(&self, inputs: &[PathBuf]) -> Result<()> {
        let inputs: Vec<Named> = inputs
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let label = if i == 0 {
                    "the grid file"
                } else {
                    "a file the grid reads (INCLUDE or INIT)"
                };
                Named::new(label, p)
            })
            .collect();
        Ok(check_outputs(&self.0, &inputs)?)
    }
}
