//! Atomic output files: every writer of the crate writes to a temporary file
//! in the destination's folder and renames it into place once the whole file
//! is written, so that an interrupted or failed run never leaves half a file
//! where a good one was (the old file, if any, stays as it was).
//!
//! - A destination that exists and is not a regular file (a directory, a
//!   named pipe, a device node, a socket, or a symbolic link to one) is
//!   refused before anything is written: a rename would replace the node
//!   with a plain file ([`not_a_regular_file`]).
//! - A temporary file is removed whenever it is not committed: an error
//!   while writing, flushing (a full disk, a file size limit) or renaming,
//!   a panic, or a drop.
//! - Every live temporary file is listed in a process-wide registry, so
//!   that a program interrupted by a signal can remove them before it ends
//!   ([`remove_temporaries`]). The library installs no signal handler: the
//!   program decides (the CLI does, for SIGINT, SIGTERM and SIGHUP).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// The live temporary files of this process, by sequence number, and
/// whether the process is ending (no new temporary file is created then).
struct Registry {
    next: u64,
    live: BTreeMap<u64, PathBuf>,
    ending: bool,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    next: 0,
    live: BTreeMap::new(),
    ending: false,
});

/// The registry, even after a panic while it was held (its data stays
/// consistent: every change is one insert or remove).
fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every temporary file this process is writing and makes any
/// later [`AtomicFile::create`] fail: for a program about to end on a
/// signal (call it from a thread that receives signals, not from an
/// asynchronous signal handler). Destinations are left as they were.
/// Returns how many temporary files were removed.
pub fn remove_temporaries() -> usize {
    let mut r = registry();
    r.ending = true;
    let live = std::mem::take(&mut r.live);
    live.values()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

/// [`remove_temporaries`] for a process that is out of memory: takes the
/// registry only if no thread holds it (the failing allocation may be
/// inside it) and allocates nothing (a short path is turned into a C
/// string on the stack; a longer one may fail to be removed). Returns how
/// many temporary files were removed.
pub fn remove_temporaries_without_allocating() -> usize {
    let Ok(mut r) = REGISTRY.try_lock() else {
        return 0;
    };
    r.ending = true;
    let live = std::mem::take(&mut r.live);
    let removed = live
        .values()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count();
    // Dropping the map frees memory; it never allocates.
    drop(live);
    removed
}

/// A file being written: bytes go to a temporary sibling of the destination;
/// [`AtomicFile::commit`] renames it into place. Dropped without a commit,
/// or when the commit fails, the temporary file is removed and the
/// destination is left untouched.
#[derive(Debug)]
pub struct AtomicFile {
    tmp: PathBuf,
    dest: PathBuf,
    /// The key of `tmp` in the registry.
    seq: u64,
    w: Option<BufWriter<File>>,
    committed: bool,
}

/// The path a write to `path` really replaces: the target of a symbolic
/// link (so that the link is kept), else `path` itself.
fn resolve(path: &Path) -> PathBuf {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => std::fs::canonicalize(path).unwrap_or(path.into()),
        _ => path.into(),
    }
}

/// What an existing `path` is, in words, when it is not a regular file
/// (symbolic links followed): "a directory", "a named pipe (FIFO)",
/// "a character device", "a block device", "a socket", each with
/// "a symbolic link to TARGET, " in front when `path` is a link. `None`
/// when `path` is a regular file or does not exist (a dangling link
/// included: the write creates its target).
pub fn not_a_regular_file(path: &Path) -> Option<String> {
    let m = std::fs::metadata(path).ok()?;
    let t = m.file_type();
    if t.is_file() {
        return None;
    }
    let what = if t.is_dir() {
        "a directory"
    } else {
        special_kind(&t)
    };
    let link = std::fs::symlink_metadata(path).is_ok_and(|l| l.file_type().is_symlink());
    Some(if link {
        let target = std::fs::canonicalize(path).unwrap_or_else(|_| path.into());
        format!("a symbolic link to {}, {what}", target.display())
    } else {
        what.to_string()
    })
}

#[cfg(unix)]
fn special_kind(t: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_fifo() {
        "a named pipe (FIFO)"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &std::fs::FileType) -> &'static str {
    "not a regular file"
}

/// The error for a destination that is not a regular file (callers name
/// the path: `cannot write PATH: it is …`).
fn refuse(what: &str) -> io::Error {
    let kind = if what == "a directory" {
        io::ErrorKind::IsADirectory
    } else {
        io::ErrorKind::InvalidInput
    };
    io::Error::new(
        kind,
        format!("it is {what}, not a regular file: refusing to replace it; nothing was written"),
    )
}

impl AtomicFile {
    /// Opens a temporary file beside `dest` (same folder, hidden name with
    /// the process id), buffered by 1 MiB. Refuses a `dest` that exists and
    /// is not a regular file ([`not_a_regular_file`]), naming it.
    pub fn create(dest: impl AsRef<Path>) -> io::Result<Self> {
        let given = dest.as_ref();
        if let Some(what) = not_a_regular_file(given) {
            return Err(refuse(&what));
        }
        let dest = resolve(given);
        let name = dest
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the path names no file"))?;
        let dir = match dest.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        // Created and registered under the lock: a signal-driven
        // `remove_temporaries` sees every temporary file that exists.
        let mut r = registry();
        if r.ending {
            return Err(io::Error::new(
                io::ErrorKind::Interrupted,
                "the program is ending on a signal",
            ));
        }
        let seq = r.next;
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".{}.{seq}.tmp", std::process::id()));
        let tmp = dir.join(tmp_name);
        let f = File::create(&tmp)?;
        r.next += 1;
        r.live.insert(seq, tmp.clone());
        drop(r);
        Ok(AtomicFile {
            tmp,
            dest,
            seq,
            w: Some(BufWriter::with_capacity(1 << 20, f)),
            committed: false,
        })
    }

    /// The destination (a symbolic link's target when `dest` was one).
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// The temporary file the bytes go to until the commit.
    pub fn temporary(&self) -> &Path {
        &self.tmp
    }

    /// Flushes, then renames the temporary file onto the destination. On
    /// an error the temporary file is removed and the destination is left
    /// as it was.
    pub fn commit(mut self) -> io::Result<()> {
        let w = self.w.take().expect("not yet committed");
        let f = w.into_inner().map_err(|e| e.into_error())?;
        // Keep the mode of the file being replaced (umask default otherwise).
        if let Ok(m) = std::fs::metadata(&self.dest) {
            let _ = f.set_permissions(m.permissions());
        }
        drop(f);
        let mut r = registry();
        if r.ending {
            return Err(io::Error::new(
                io::ErrorKind::Interrupted,
                "the program is ending on a signal",
            ));
        }
        std::fs::rename(&self.tmp, &self.dest)?;
        r.live.remove(&self.seq);
        self.committed = true;
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.w.as_mut().expect("open").write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.w.as_mut().expect("open").write_all(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.w.as_mut().expect("open").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        // Discard what is still buffered: a BufWriter flushes on drop.
        if let Some(w) = self.w.take() {
            drop(w.into_parts());
        }
        let mut r = registry();
        if r.live.remove(&self.seq).is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `dest` atomically: `body` writes the whole content, then the
/// file is renamed into place. On any error nothing replaces `dest` and no
/// temporary file is left.
pub fn write_with(
    dest: impl AsRef<Path>,
    body: impl FnOnce(&mut AtomicFile) -> io::Result<()>,
) -> io::Result<()> {
    let mut f = AtomicFile::create(dest)?;
    body(&mut f)?;
    f.commit()
}

/// Writes `bytes` to `dest` atomically.
pub fn write_bytes(dest: impl AsRef<Path>, bytes: &[u8]) -> io::Result<()> {
    write_with(dest, |w| w.write_all(bytes))
}
