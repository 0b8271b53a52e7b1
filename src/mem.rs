//! Large allocations: fallible ones that name what they hold, and hints
//! for the large per-vertex arrays that the sweep reads.
//!
//! Every allocation whose size comes from the input (file bytes, points,
//! connectivity, properties, ZCORN/COORD, level lists, outputs) goes
//! through [`try_vec`], [`try_filled`] or [`try_reserve`]: when the memory
//! is not there they return an [`AllocError`] naming the array and its
//! bytes, which each module's error carries, instead of aborting the
//! process ("memory allocation of N bytes failed"). While one of them asks
//! the allocator, [`fallible_now`] is true on that thread: a global
//! allocator that ends the process on failure (the CLI's) lets those
//! requests fail instead.

use std::cell::Cell;

/// The words every out-of-memory message starts with (front ends use them
/// to raise their own out-of-memory error, e.g. Python's `MemoryError`).
pub const OUT_OF_MEMORY: &str = "out of memory";

/// An allocation that failed: what it was for and how many bytes.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("out of memory: {what} needs {bytes} bytes, which could not be allocated")]
pub struct AllocError {
    /// What the memory was for ("ZCORN", "the file's bytes", ...).
    pub what: String,
    /// Bytes asked for (saturated at `usize::MAX` when they overflow).
    pub bytes: usize,
}

impl AllocError {
    /// The error for `n` items of `T` for `what`.
    pub fn of<T>(n: usize, what: impl Into<String>) -> AllocError {
        AllocError {
            what: what.into(),
            bytes: n.saturating_mul(std::mem::size_of::<T>()),
        }
    }
}

impl From<AllocError> for std::io::Error {
    fn from(e: AllocError) -> std::io::Error {
        std::io::Error::new(std::io::ErrorKind::OutOfMemory, e)
    }
}

thread_local! {
    static FALLIBLE: Cell<bool> = const { Cell::new(false) };
}

/// Whether this thread is inside a fallible allocation of this module (a
/// global allocator should then return null rather than end the process).
/// Never allocates.
pub fn fallible_now() -> bool {
    FALLIBLE.try_with(Cell::get).unwrap_or(false)
}

/// Runs `f` with [`fallible_now`] true on this thread.
fn fallibly<R>(f: impl FnOnce() -> R) -> R {
    let was = FALLIBLE.with(|c| c.replace(true));
    let r = f();
    FALLIBLE.with(|c| c.set(was));
    r
}

/// Makes room for `extra` more items in `v`, or says that `what` could not
/// get the memory (the vector is left as it was).
pub fn try_reserve<T>(v: &mut Vec<T>, extra: usize, what: &str) -> Result<(), AllocError> {
    fallibly(|| v.try_reserve_exact(extra))
        .map_err(|_| AllocError::of::<T>(v.len().saturating_add(extra), what))
}

/// Makes room for `extra` more items in `v` as `Vec::reserve` does (the
/// capacity at least doubles, so repeated appends stay linear), or says
/// that `what` could not get the memory (the vector is left as it was).
pub fn try_grow<T>(v: &mut Vec<T>, extra: usize, what: &str) -> Result<(), AllocError> {
    fallibly(|| v.try_reserve(extra))
        .map_err(|_| AllocError::of::<T>(v.len().saturating_add(extra), what))
}

/// An empty vector with room for `n` items (transparent huge pages asked
/// for as in [`huge_vec`]), or an error naming `what`.
pub fn try_vec<T>(n: usize, what: &str) -> Result<Vec<T>, AllocError> {
    let mut v = Vec::new();
    try_reserve(&mut v, n, what)?;
    let bytes = n.saturating_mul(std::mem::size_of::<T>());
    if bytes >= HUGE_MIN_BYTES {
        advise_huge(v.as_ptr() as usize, bytes);
    }
    Ok(v)
}

/// `n` copies of `value`, or an error naming `what`.
pub fn try_filled<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, AllocError> {
    let mut v = try_vec(n, what)?;
    v.resize(n, value);
    Ok(v)
}

/// The rest of `f` (from its current position) in a vector sized from its
/// length first: an [`AllocError`] for "the file's bytes" when they do not
/// fit in memory (as an `io::Error` of kind `OutOfMemory`), else the read.
pub fn read_file(mut f: &std::fs::File) -> std::io::Result<Vec<u8>> {
    let len = f.metadata().map(|m| m.len()).unwrap_or(0);
    let n = usize::try_from(len).unwrap_or(usize::MAX);
    let mut bytes = try_vec(n, "the file's bytes")?;
    std::io::Read::read_to_end(&mut f, &mut bytes)?;
    Ok(bytes)
}

/// Arrays at least this large ask for transparent huge pages.
const HUGE_MIN_BYTES: usize = 8 << 20;

/// Transparent huge page size on x86_64 and most aarch64 kernels.
const HUGE_PAGE: usize = 2 << 20;

/// An empty vector with room for `n` items. When that spans at least
/// 8 MiB, the kernel is asked (Linux `madvise(MADV_HUGEPAGE)`, before any
/// page is touched) to back it with transparent huge pages: the sweep reads
/// rows of φ, positions and attributes a grid layer apart, more pages than
/// the TLB covers at 4 KiB (warped 256³, 200 levels, alternating runs:
/// sweep 0.883–0.911 s → 0.820–0.848 s). A hint only:
/// without THP, or on other systems, it is a plain allocation.
pub fn huge_vec<T>(n: usize) -> Vec<T> {
    let v = Vec::with_capacity(n);
    let bytes = n.saturating_mul(std::mem::size_of::<T>());
    if bytes >= HUGE_MIN_BYTES {
        advise_huge(v.as_ptr() as usize, bytes);
    }
    v
}

/// `madvise(MADV_HUGEPAGE)` over the whole huge pages inside
/// `start..start + bytes`.
#[cfg(target_os = "linux")]
fn advise_huge(start: usize, bytes: usize) {
    let first = start.next_multiple_of(HUGE_PAGE);
    let end = (start + bytes) / HUGE_PAGE * HUGE_PAGE;
    if end > first {
        // SAFETY: the range lies inside one live allocation of ours;
        // MADV_HUGEPAGE changes no contents and no permissions, and a
        // failure (THP disabled) leaves the memory as it was.
        unsafe {
            libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge(_start: usize, _bytes: usize) {}

/// `s` cut into consecutive parts of the given lengths (which sum to its
/// length), to be filled in parallel.
pub(crate) fn split_lengths<'a, T>(mut s: &'a mut [T], lens: &[usize]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(lens.len());
    for &l in lens {
        let (a, b) = std::mem::take(&mut s).split_at_mut(l);
        out.push(a);
        s = b;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An impossible request is an error naming the array and its bytes;
    /// a possible one is a plain vector.
    #[test]
    fn fallible_allocations_name_what_failed() {
        let e = try_vec::<u64>(usize::MAX / 16, "ZCORN").unwrap_err();
        assert_eq!(e.bytes, (usize::MAX / 16) * 8);
        assert!(e.to_string().starts_with(OUT_OF_MEMORY), "{e}");
        assert!(e.to_string().contains("ZCORN"), "{e}");
        let e = try_filled(1 << 62, 0u8, "cells").unwrap_err();
        assert_eq!(e.bytes, 1 << 62);
        let mut v = vec![1u32; 3];
        assert!(try_reserve(&mut v, usize::MAX / 2, "points").is_err());
        assert_eq!(v, [1, 1, 1]);
        assert_eq!(try_filled(5, 7u16, "x").unwrap(), [7; 5]);
        assert!(!fallible_now());
        let io: std::io::Error = e.into();
        assert_eq!(io.kind(), std::io::ErrorKind::OutOfMemory);
    }

    /// Large and small vectors behave as plain ones: capacity, contents.
    #[test]
    fn huge_vec_is_a_plain_vector() {
        for n in [0usize, 1, 1000, 3 << 20, (8 << 20) / 4 + 7] {
            let mut v: Vec<f32> = huge_vec(n);
            assert!(v.capacity() >= n && v.is_empty());
            v.extend((0..n).map(|i| i as f32));
            assert_eq!(v.len(), n);
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as f32));
        }
    }
}
