//! Read-only memory maps of input files that survive the file being
//! truncated under them.
//!
//! A page of a file map that lies past the file's end (another process
//! truncated it while it was read) faults with SIGBUS, which kills the
//! process without a word. Every map the crate reads is a [`MappedFile`]:
//! its address range is registered in a process-wide table, and a SIGBUS
//! handler (installed once, on the first map) replaces the faulting page
//! and the rest of that map with anonymous zero pages, marks the map as
//! faulted and returns, so the interrupted read goes on over zeros. The
//! reader then calls [`MappedFile::check`] before returning, which turns a
//! faulted or shrunk map into an error naming what happened; a parse that
//! failed on the zeros reports the truncation, not the zeros.
//!
//! The handler chains: a SIGBUS at an address outside every registered map
//! (or sent by `kill`) goes to the handler that was installed before
//! (Rust's stack-overflow guard, Python's `faulthandler`, an embedding
//! application's), or, where there was none, is delivered as the default
//! action (the process dies as it would have). It is safe inside a Python
//! interpreter: it touches only atomics and calls `mmap`, and leaves every
//! other SIGBUS to whoever handled it before. A handler that someone
//! installs after ours and that does not chain takes SIGBUS away from us;
//! then a truncation kills the process as before.
//!
//! Only Linux installs the handler; elsewhere [`MappedFile::map`] returns
//! `None` and callers read the file instead.

use std::fs::File;
use std::io;
use std::ops::Deref;

use memmap2::Mmap;

/// A read-only map of a whole file, registered with the SIGBUS handler for
/// as long as it lives. Dereferences to the file's bytes as they were
/// mapped (zeros where the file was truncated meanwhile).
pub struct MappedFile {
    /// The map (unmapped on drop, after the slot is released).
    map: Mmap,
    /// The file, kept to compare its length at [`MappedFile::check`].
    file: File,
    /// This map's slot in the handler's table.
    slot: usize,
}

impl MappedFile {
    /// Maps all of `file` read-only and registers the map, or `None` when
    /// it cannot be mapped safely here (an empty file, a failed `mmap`, a
    /// full table of maps, a system without the handler): the caller
    /// then reads the file.
    pub fn map(file: File) -> Option<MappedFile> {
        if !imp::install() {
            return None;
        }
        // SAFETY: a read-only shared map. The file may change under it:
        // bytes that change are read as they are (no Rust reference
        // assumes them fixed beyond a parse that validates what it reads),
        // and pages past a new end are replaced by zeros by the handler
        // registered below before anything reads them.
        let map = unsafe { Mmap::map(&file) }.ok()?;
        if map.is_empty() {
            return None;
        }
        let slot = imp::register(map.as_ptr() as usize, map.len())?;
        Some(MappedFile { map, file, slot })
    }

    /// `Ok` when the map held the file's bytes throughout: the file is
    /// still at least as long as when it was mapped and no page of the map
    /// faulted. Otherwise an error saying the file was truncated while it
    /// was read (with its length now and then), or that a page could not
    /// be read. Callers put their file name in front.
    pub fn check(&self) -> io::Result<()> {
        let mapped = self.map.len() as u64;
        let now = self.file.metadata().map(|m| m.len());
        match now {
            Ok(n) if n < mapped => Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                format!(
                    "the file was truncated while being read ({n} bytes now, {mapped} when it was opened)"
                ),
            )),
            _ if imp::faulted(self.slot) => Err(io::Error::other(
                "a page of the file could not be read while it was being read (SIGBUS on its memory map)",
            )),
            Ok(_) => Ok(()),
            Err(e) => Err(e),
        }
    }

    /// Returns `r`, unless the map was truncated or faulted ([`Self::check`]):
    /// then that error, built by `err`, whatever `r` was (a parse that ran
    /// over zeros fails for that reason, not for the zeros).
    pub fn settle<T, E>(&self, r: Result<T, E>, err: impl FnOnce(io::Error) -> E) -> Result<T, E> {
        match self.check() {
            Ok(()) => r,
            Err(e) => Err(err(e)),
        }
    }

    /// Drops the pages of `from..from + len` (page-aligned) from this
    /// process's memory; the page cache keeps them and a later read faults
    /// them in again (the same bytes, or zeros where the handler put them).
    pub fn release(&self, from: usize, len: usize) {
        // SAFETY: a read-only map of a file: MADV_DONTNEED discards no
        // data, and the caller reads nothing there any more.
        let _ = unsafe {
            self.map
                .unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, from, len)
        };
    }
}

impl Deref for MappedFile {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.map
    }
}

impl Drop for MappedFile {
    fn drop(&mut self) {
        imp::unregister(self.slot);
    }
}

#[cfg(target_os = "linux")]
mod imp {
    use std::sync::OnceLock;
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

    use libc::{c_int, c_void, siginfo_t};

    /// Maps that can be live at once; a map beyond them is not made (the
    /// caller reads the file instead).
    const SLOTS: usize = 64;

    /// One registered map: `[start, end)` (0 when free), whether a page of
    /// it faulted, whether the slot is taken.
    struct Slot {
        start: AtomicUsize,
        end: AtomicUsize,
        faulted: AtomicBool,
        taken: AtomicBool,
    }

    #[allow(clippy::declare_interior_mutable_const)]
    const FREE: Slot = Slot {
        start: AtomicUsize::new(0),
        end: AtomicUsize::new(0),
        faulted: AtomicBool::new(false),
        taken: AtomicBool::new(false),
    };

    static TABLE: [Slot; SLOTS] = [FREE; SLOTS];

    /// The page size, read once before the handler is installed.
    static PAGE: AtomicUsize = AtomicUsize::new(4096);

    /// The SIGBUS action before ours (what other SIGBUS go to).
    struct Prev(libc::sigaction);
    // SAFETY: a plain C struct (a handler address, flags, a mask) that is
    // written once before it is shared and only read afterwards.
    unsafe impl Sync for Prev {}
    unsafe impl Send for Prev {}
    static PREV: OnceLock<Prev> = OnceLock::new();

    /// Installs the handler once; whether it is installed.
    pub(super) fn install() -> bool {
        static OK: OnceLock<bool> = OnceLock::new();
        *OK.get_or_init(|| {
            // SAFETY: sysconf and sigaction with valid arguments; the new
            // action's handler is `on_sigbus`, of the SA_SIGINFO type.
            unsafe {
                let page = libc::sysconf(libc::_SC_PAGESIZE);
                if page > 0 {
                    PAGE.store(page as usize, Ordering::Relaxed);
                }
                let mut old: libc::sigaction = std::mem::zeroed();
                if libc::sigaction(libc::SIGBUS, std::ptr::null(), &mut old) != 0 {
                    return false;
                }
                let _ = PREV.set(Prev(old));
                let mut new: libc::sigaction = std::mem::zeroed();
                new.sa_sigaction = on_sigbus as *const () as usize;
                new.sa_flags = libc::SA_SIGINFO | libc::SA_ONSTACK;
                libc::sigemptyset(&mut new.sa_mask);
                libc::sigaction(libc::SIGBUS, &new, std::ptr::null_mut()) == 0
            }
        })
    }

    /// Registers `[start, start + len)`; its slot, or `None` when all are taken.
    pub(super) fn register(start: usize, len: usize) -> Option<usize> {
        let page = PAGE.load(Ordering::Relaxed);
        let end = (start + len).next_multiple_of(page);
        let i = TABLE.iter().position(|s| {
            s.taken
                .compare_exchange(false, true, Ordering::AcqRel, Ordering::Relaxed)
                .is_ok()
        })?;
        let s = &TABLE[i];
        s.faulted.store(false, Ordering::Relaxed);
        s.end.store(end, Ordering::Relaxed);
        s.start.store(start, Ordering::Release);
        Some(i)
    }

    /// Frees slot `i` (its map is about to be unmapped).
    pub(super) fn unregister(i: usize) {
        let s = &TABLE[i];
        s.start.store(0, Ordering::Release);
        s.end.store(0, Ordering::Relaxed);
        s.taken.store(false, Ordering::Release);
    }

    /// Whether a page of slot `i`'s map faulted.
    pub(super) fn faulted(i: usize) -> bool {
        TABLE[i].faulted.load(Ordering::Acquire)
    }

    /// The SIGBUS handler: a fault inside a registered map gets zero pages
    /// from the faulting page to the map's end (the file ends before it),
    /// and the faulting read is restarted; anything else is chained.
    extern "C" fn on_sigbus(sig: c_int, info: *mut siginfo_t, ctx: *mut c_void) {
        // SAFETY: the kernel passes a valid siginfo_t to an SA_SIGINFO
        // handler; si_addr is the faulting address for kernel-sent SIGBUS.
        let (code, addr) = unsafe { ((*info).si_code, (*info).si_addr() as usize) };
        if code > 0 {
            let page = PAGE.load(Ordering::Relaxed);
            for s in &TABLE {
                let start = s.start.load(Ordering::Acquire);
                let end = s.end.load(Ordering::Relaxed);
                if start == 0 || addr < start || addr >= end {
                    continue;
                }
                let from = addr / page * page;
                // SAFETY: `from..end` lies inside a live read-only map of
                // ours (registered until it is unmapped); MAP_FIXED
                // replaces those pages with private zero pages, which
                // munmap of the whole map later removes like any other.
                let p = unsafe {
                    libc::mmap(
                        from as *mut c_void,
                        end - from,
                        libc::PROT_READ,
                        libc::MAP_FIXED | libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                        -1,
                        0,
                    )
                };
                if p != libc::MAP_FAILED {
                    s.faulted.store(true, Ordering::Release);
                    return;
                }
                break;
            }
        }
        chain(sig, info, ctx, code);
    }

    /// Hands a SIGBUS that is not ours to the action installed before.
    fn chain(sig: c_int, info: *mut siginfo_t, ctx: *mut c_void, code: c_int) {
        let prev = PREV.get().map(|p| p.0);
        let handler = prev.map_or(libc::SIG_DFL, |p| p.sa_sigaction);
        if handler == libc::SIG_IGN && code <= 0 {
            return;
        }
        if handler != libc::SIG_DFL && handler != libc::SIG_IGN {
            let siginfo = prev.is_some_and(|p| p.sa_flags & libc::SA_SIGINFO != 0);
            // SAFETY: the previous action's handler, called with the
            // arguments of the type its flags declare.
            unsafe {
                if siginfo {
                    let f: extern "C" fn(c_int, *mut siginfo_t, *mut c_void) =
                        std::mem::transmute(handler);
                    f(sig, info, ctx);
                } else {
                    let f: extern "C" fn(c_int) = std::mem::transmute(handler);
                    f(sig);
                }
            }
            return;
        }
        // The default action: restore it; a fault is raised again when the
        // read restarts, a signal sent by kill is raised here.
        // SAFETY: sigaction and raise are async-signal-safe.
        unsafe {
            let mut dfl: libc::sigaction = std::mem::zeroed();
            dfl.sa_sigaction = libc::SIG_DFL;
            libc::sigemptyset(&mut dfl.sa_mask);
            libc::sigaction(sig, &dfl, std::ptr::null_mut());
            if code <= 0 {
                libc::raise(sig);
            }
        }
    }
}

#[cfg(not(target_os = "linux"))]
mod imp {
    pub(super) fn install() -> bool {
        false
    }
    pub(super) fn register(_start: usize, _len: usize) -> Option<usize> {
        None
    }
    pub(super) fn unregister(_i: usize) {}
    pub(super) fn faulted(_i: usize) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::MappedFile;
    use std::io::Write;

    /// A map of a file truncated to a third: reading it all gives the
    /// first third's bytes and zeros after, and `check` names the
    /// truncation; a second map of the restored file reads cleanly.
    #[test]
    fn a_truncated_map_reads_zeros_and_reports() {
        let dir = std::env::temp_dir().join(format!("ss-mapped-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.bin");
        let bytes: Vec<u8> = (0..3 << 20).map(|i| (i % 251) as u8 + 1).collect();
        std::fs::File::create(&path)
            .unwrap()
            .write_all(&bytes)
            .unwrap();
        let map = MappedFile::map(std::fs::File::open(&path).unwrap()).unwrap();
        assert!(map.check().is_ok());
        let cut: usize = (1 << 20) + 123;
        std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .unwrap()
            .set_len(cut as u64)
            .unwrap();
        let page = 4096;
        let kept = cut.next_multiple_of(page);
        assert_eq!(&map[..cut], &bytes[..cut]);
        assert!(map[kept..].iter().all(|&b| b == 0));
        let e = map.check().unwrap_err().to_string();
        assert!(e.contains("truncated while being read"), "{e}");
        drop(map);
        std::fs::write(&path, &bytes).unwrap();
        let again = MappedFile::map(std::fs::File::open(&path).unwrap()).unwrap();
        assert_eq!(&again[..], &bytes[..]);
        assert!(again.check().is_ok());
        drop(again);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
