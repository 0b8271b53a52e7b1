//! The CLI's checks on its arguments, made before any file is read or
//! written: the library's limits ([`stratasweep::limits`]: levels,
//! threads, frames, repeats; render options are the policy's) with each error
//! naming the flag, output extensions, and output paths against input
//! paths (`io::guard`).

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use stratasweep::io::guard::{Named, check_outputs, known_inputs};
use stratasweep::limits::{self, LimitError};
use stratasweep::policy::{Opt, PolicyError, Spelling, Value};

/// The CLI's spelling of the policy's options: `--z-scale`, `--mode iso`,
/// `-o` for the mesh output.
pub struct Flags;

impl Spelling for Flags {
    fn spell(&self, opt: Opt, value: Option<&Value>) -> String {
        let flag = match opt {
            Opt::Mesh => "-o".to_string(),
            o => format!("--{}", o.name().replace('_', "-")),
        };
        match value {
            None | Some(Value::Bool(true)) => flag,
            Some(Value::Word(w)) => format!("{flag} {w}"),
            Some(Value::Bool(false)) => format!("leave out {flag}"),
        }
    }
}

/// A refusal of the policy in the CLI's words.
pub fn policy_error(e: PolicyError) -> anyhow::Error {
    anyhow::anyhow!(e.spelled(&Flags))
}

/// The library's limit error with the argument called by its flag.
pub fn flag(name: &str) -> impl Fn(LimitError) -> anyhow::Error + '_ {
    move |e| anyhow::anyhow!(e.named(name))
}

/// Refuses 0 or more than [`limits::max_threads`] threads (`--threads`).
pub fn check_threads(n: usize) -> Result<()> {
    limits::check_threads(n).map_err(flag("--threads"))?;
    Ok(())
}

/// Refuses a level count of 0 or over [`limits::MAX_LEVELS`] (`--count`).
pub fn check_count(k: usize) -> Result<()> {
    limits::check_count(k).map_err(flag("--count"))?;
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
    limits::check_values(n).map_err(|e| anyhow::anyhow!(e.named(&format!("--values '{s}'"))))?;
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
