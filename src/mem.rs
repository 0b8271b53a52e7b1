//! Allocation hints for the large per-vertex arrays that the sweep reads.

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

#[cfg(test)]
mod tests {
    use super::huge_vec;

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
