//! Atomic output files: every writer of the crate writes to a temporary file
//! in the destination's folder and renames it into place once the whole file
//! is written, so that an interrupted or failed run never leaves half a file
//! where a good one was (the old file, if any, stays as it was).

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes the temporary files of one process.
static SEQ: AtomicU64 = AtomicU64::new(0);

/// A file being written: bytes go to a temporary sibling of the destination;
/// [`AtomicFile::commit`] renames it into place. Dropped without a commit,
/// the temporary file is removed and the destination is left untouched.
#[derive(Debug)]
pub struct AtomicFile {
    tmp: PathBuf,
    dest: PathBuf,
    w: Option<BufWriter<File>>,
}

/// The path a write to `path` really replaces: the target of a symbolic
/// link (so that the link is kept), else `path` itself.
fn resolve(path: &Path) -> PathBuf {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => std::fs::canonicalize(path).unwrap_or(path.into()),
        _ => path.into(),
    }
}

impl AtomicFile {
    /// Opens a temporary file beside `dest` (same folder, hidden name with
    /// the process id), buffered by 1 MiB.
    pub fn create(dest: impl AsRef<Path>) -> io::Result<Self> {
        let dest = resolve(dest.as_ref());
        let name = dest
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the path names no file"))?;
        let dir = match dest.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        if dest.is_dir() {
            return Err(io::Error::new(
                io::ErrorKind::IsADirectory,
                "it is a directory",
            ));
        }
        let seq = SEQ.fetch_add(1, Ordering::Relaxed);
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".{}.{seq}.tmp", std::process::id()));
        let tmp = dir.join(tmp_name);
        let f = File::create(&tmp)?;
        Ok(AtomicFile {
            tmp,
            dest,
            w: Some(BufWriter::with_capacity(1 << 20, f)),
        })
    }

    /// The destination (a symbolic link's target when `dest` was one).
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Flushes, then renames the temporary file onto the destination.
    pub fn commit(mut self) -> io::Result<()> {
        let w = self.w.take().expect("not yet committed");
        let f = w.into_inner().map_err(|e| e.into_error())?;
        // Keep the mode of the file being replaced (umask default otherwise).
        if let Ok(m) = std::fs::metadata(&self.dest) {
            let _ = f.set_permissions(m.permissions());
        }
        drop(f);
        std::fs::rename(&self.tmp, &self.dest)
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
        if self.w.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `dest` atomically: `body` writes the whole content, then the
/// file is renamed into place. On any error nothing replaces `dest`.
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
