//! The `stratasweep` command line: info, slice, generate, bench, render, view.

mod cli;

use std::alloc::{GlobalAlloc, Layout, System};

/// The system allocator, except that an allocation that fails outside the
/// library's fallible helpers (`stratasweep::mem`) ends the process with
/// "stratasweep: out of memory: …" and exit code [`OOM_EXIT`] instead of
/// Rust's "memory allocation of N bytes failed" and SIGABRT. The large
/// arrays sized by the input go through the fallible helpers and come back
/// as errors naming the array; this catches whatever is left.
struct ReportOom;

/// Exit code after an allocation failure the program could not handle.
const OOM_EXIT: i32 = 3;

// SAFETY: every call is forwarded to `System` with the same arguments; a
// null result is returned as it is, or the process ends without returning.
unsafe impl GlobalAlloc for ReportOom {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        checked(unsafe { System.alloc(l) }, l.size())
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        checked(unsafe { System.alloc_zeroed(l) }, l.size())
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, size: usize) -> *mut u8 {
        // SAFETY: forwarded with the caller's pointer, layout and size.
        checked(unsafe { System.realloc(p, l, size) }, size)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: forwarded with the caller's pointer and layout.
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static ALLOCATOR: ReportOom = ReportOom;

/// `p`, unless it is null outside a fallible request: then [`out_of_memory`].
fn checked(p: *mut u8, size: usize) -> *mut u8 {
    if p.is_null() && !stratasweep::mem::fallible_now() {
        out_of_memory(size);
    }
    p
}

/// Says that `size` bytes could not be allocated and ends the process
/// (exit code [`OOM_EXIT`]). Allocates nothing: the message is built on the
/// stack and written with one `write(2)`.
///
/// Removes the temporary output files (`io::atomic`'s registry, without
/// allocating) before `_exit`.
fn out_of_memory(size: usize) -> ! {
    let mut buf = [0u8; 400];
    let mut n = 0;
    let mut put = |s: &[u8]| {
        let k = s.len().min(buf.len() - n);
        buf[n..n + k].copy_from_slice(&s[..k]);
        n += k;
    };
    put(b"stratasweep: out of memory: an allocation of ");
    let mut digits = [0u8; 20];
    let mut d = digits.len();
    let mut v = size;
    loop {
        d -= 1;
        digits[d] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    put(&digits[d..]);
    put(b" bytes failed");
    // try_lock: the failing thread may hold the lock (never for long).
    if let Ok(c) = CONTEXT.try_lock()
        && c.1 > 0
    {
        put(b" while ");
        put(&c.0[..c.1]);
    }
    put(b" (free memory or raise the memory limit)\n");
    // The outputs being written stay as they were: their temporaries go.
    stratasweep::io::atomic::remove_temporaries_without_allocating();
    #[cfg(unix)]
    // SAFETY: write(2) of our own stack buffer, then _exit(2), which runs
    // no destructor and no atexit handler (nothing that could allocate).
    unsafe {
        libc::write(2, buf.as_ptr().cast(), n);
        libc::_exit(OOM_EXIT);
    }
    #[cfg(not(unix))]
    {
        use std::io::Write;
        let _ = std::io::stderr().write_all(&buf[..n]);
        std::process::exit(OOM_EXIT);
    }
}

/// What the program is doing, for the out-of-memory message ("reading
/// X", "building the sweep structure of X"): a fixed buffer, so that the
/// message needs no allocation.
static CONTEXT: std::sync::Mutex<([u8; 240], usize)> = std::sync::Mutex::new(([0; 240], 0));

/// Records `what` (cut to 240 bytes) as what the program is doing, named
/// by the out-of-memory message if an allocation fails from now on.
pub(crate) fn oom_context(what: &str) {
    let mut end = what.len().min(240);
    while !what.is_char_boundary(end) {
        end -= 1;
    }
    if let Ok(mut c) = CONTEXT.lock() {
        c.0[..end].copy_from_slice(&what.as_bytes()[..end]);
        c.1 = end;
    }
}

fn main() {
    cli::main()
}
