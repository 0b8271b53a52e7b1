//! Output paths checked against input paths before anything is written:
//! an output must never name an input file (the grid, an INCLUDE, the INIT
//! beside an EGRID, a transfer function) nor another output, nor an
//! existing node that is not a regular file (a directory, a named pipe, a
//! device, a socket, or a symbolic link to one), which the rename of an
//! atomic write would replace with a plain file. Paths are
//! compared as files, not strings: symbolic links, `./` and `..`
//! spellings and hard links of the same file all count as the same file.
//! Labels (`"-o"`, `"--stats"`, `"the grid"`) come from the caller.

use std::path::{Path, PathBuf};

use thiserror::Error;

/// A labelled path: what the caller calls it (a flag, a role) and where it is.
#[derive(Clone, Debug)]
pub struct Named {
    /// How the user knows this path (`-o`, `--stats`, `the grid file`).
    pub label: String,
    /// The path as given.
    pub path: PathBuf,
}

impl Named {
    /// A labelled path.
    pub fn new(label: impl Into<String>, path: impl Into<PathBuf>) -> Self {
        Named {
            label: label.into(),
            path: path.into(),
        }
    }
}

/// An output path that must not be written: it names an input, another
/// output, or something that is not a regular file.
#[derive(Debug, Error)]
pub enum Clash {
    /// An output exists and is not a regular file.
    #[error(
        "refusing to write {label} {}: it is {what}, not a regular file; nothing was written",
        path.display()
    )]
    NotAFile {
        /// The output's label.
        label: String,
        /// The output path as given.
        path: PathBuf,
        /// What it is (`atomic::not_a_regular_file`).
        what: String,
    },
    /// An output names an input file.
    #[error(
        "refusing to write {out_label} {}: it is {in_label} ({}), an input that would be destroyed; nothing was written",
        out.display(), input.display()
    )]
    OutputIsInput {
        /// The output's label.
        out_label: String,
        /// The output path as given.
        out: PathBuf,
        /// The input's label.
        in_label: String,
        /// The input path as given.
        input: PathBuf,
    },
    /// Two outputs name the same file.
    #[error(
        "{a_label} {} and {b_label} {} name the same file: one would overwrite the other; nothing was written",
        a.display(), b.display()
    )]
    SameOutput {
        /// The first output's label.
        a_label: String,
        /// The first output path.
        a: PathBuf,
        /// The second output's label.
        b_label: String,
        /// The second output path.
        b: PathBuf,
    },
}

/// Identity of a path as a file: (device, inode) when it exists (Unix),
/// and its canonical spelling (the folder canonicalised, the name kept when
/// the file does not exist yet).
#[derive(Debug, PartialEq, Eq)]
struct FileId {
    inode: Option<(u64, u64)>,
    canonical: PathBuf,
}

fn canonical(path: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(path) {
        return c;
    }
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    match (abs.parent(), abs.file_name()) {
        (Some(dir), Some(name)) => std::fs::canonicalize(dir)
            .map(|d| d.join(name))
            .unwrap_or(abs.clone()),
        _ => abs,
    }
}

fn file_id(path: &Path) -> FileId {
    #[cfg(unix)]
    let inode = {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
    };
    #[cfg(not(unix))]
    let inode = None;
    FileId {
        inode,
        canonical: canonical(path),
    }
}

fn same(a: &FileId, b: &FileId) -> bool {
    match (a.inode, b.inode) {
        (Some(x), Some(y)) => x == y,
        _ => a.canonical == b.canonical,
    }
}

/// Refuses an output that exists and is not a regular file, then one that
/// names an input or another output (first clash found, outputs in the
/// order given).
pub fn check_outputs(outputs: &[Named], inputs: &[Named]) -> Result<(), Clash> {
    if let Some((o, what)) = outputs
        .iter()
        .find_map(|o| super::atomic::not_a_regular_file(&o.path).map(|w| (o, w)))
    {
        return Err(Clash::NotAFile {
            label: o.label.clone(),
            path: o.path.clone(),
            what,
        });
    }
    let ins: Vec<FileId> = inputs.iter().map(|n| file_id(&n.path)).collect();
    let outs: Vec<FileId> = outputs.iter().map(|n| file_id(&n.path)).collect();
    for (o, oid) in outputs.iter().zip(&outs) {
        if let Some((i, _)) = inputs.iter().zip(&ins).find(|(_, iid)| same(oid, iid)) {
            return Err(Clash::OutputIsInput {
                out_label: o.label.clone(),
                out: o.path.clone(),
                in_label: i.label.clone(),
                input: i.path.clone(),
            });
        }
    }
    for (k, (a, aid)) in outputs.iter().zip(&outs).enumerate() {
        for (b, bid) in outputs.iter().zip(&outs).skip(k + 1) {
            if same(aid, bid) {
                return Err(Clash::SameOutput {
                    a_label: a.label.clone(),
                    a: a.path.clone(),
                    b_label: b.label.clone(),
                    b: b.path.clone(),
                });
            }
        }
    }
    Ok(())
}

/// The files a grid file will pull in that can be found without parsing
/// it: the file itself and, for an EGRID, the INIT beside it. (INCLUDEs
/// are known after the load: `Loaded::inputs`.)
pub fn known_inputs(grid: &Path) -> Vec<PathBuf> {
    let mut v = vec![grid.to_path_buf()];
    if !matches!(super::load::detect(grid), Ok(super::Format::Egrid)) {
        return v;
    }
    for ext in ["INIT", "init"] {
        let p = grid.with_extension(ext);
        if p != grid && p.is_file() {
            v.push(p);
        }
    }
    v
}
