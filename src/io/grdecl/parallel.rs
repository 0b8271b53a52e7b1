//! Big numeric keywords of a memory-mapped file parsed in parallel.
//!
//! Ahead of the lexer's window, a *round* cuts the next
//! `threads × CHUNK` bytes at line starts into one chunk per thread, runs
//! the lexer's own fast path ([`scan_plain`]) over each chunk at once, and
//! takes the chunks' values in order up to the first chunk that stopped
//! before its end (at `/`, a comment, a default, a word, anything the fast
//! path leaves to the general one). The lexer then moves to where that
//! chunk stopped, with its line count, so the general path reads what
//! follows exactly as if the whole text had been read serially: same
//! values, same errors with the same lines. Chunks after the stop (the
//! next keywords, read ahead) are dropped.
//!
//! A chunk starts at a line start, so it never starts inside a token, a
//! comment or a quoted string (neither spans a line here); a file with no
//! line break near a cut point is left to the serial path.

use crate::io::mapped::MappedFile;
use rayon::prelude::*;

use super::lexer::{Lexer, Sink, Source, scan_plain};
use super::*;

/// Bytes per chunk (one chunk per thread and round).
const CHUNK: usize = 2 << 20;

/// Fewest values still expected for a round to be worth starting.
const MIN_ROOM: usize = 1 << 16;

/// How far past a cut point a line break is looked for.
const MAX_LINE: usize = 1 << 16;

/// What the fast path read from one chunk (its values in the round's
/// buffer of the same index).
struct Chunk {
    /// Values counted (repeats in full, saturating); at most the room left
    /// when the round started are kept.
    found: usize,
    /// Where it stopped (the chunk's end when it read the whole chunk).
    stop: usize,
    /// Line breaks before `stop`.
    lines: usize,
    /// Whether `stop` is at the start of a line.
    bol: bool,
    /// A repeat's values did not fit in memory.
    short: bool,
}

/// The start of the line after offset `x` in `b` (`b.len()` at the end),
/// or `None` when no line break comes within [`MAX_LINE`] bytes.
fn next_line(b: &[u8], x: usize) -> Option<usize> {
    if x >= b.len() {
        return Some(b.len());
    }
    let look = &b[x..b.len().min(x + MAX_LINE)];
    match look.iter().position(|&c| c == b'\n') {
        Some(i) => Some(x + i + 1),
        None if x + look.len() == b.len() => Some(b.len()),
        None => None,
    }
}

/// One round's chunks from `start`: `parts` ranges of about `len / parts`
/// bytes each, cut at line starts, or `None` where a cut finds no line
/// break.
fn cut(b: &[u8], start: usize, len: usize, parts: usize) -> Option<Vec<(usize, usize)>> {
    let mut ranges = Vec::with_capacity(parts);
    let mut a = start;
    for i in 1..=parts {
        let e = next_line(b, start + len * i / parts)?;
        if e > a {
            ranges.push((a, e));
            a = e;
        }
    }
    Some(ranges)
}

/// Runs the fast path over `b[a..e]` (a chunk cut at line starts) into
/// `buf` (cleared first), keeping at most `room` values.
fn scan_chunk(
    b: &[u8],
    (a, e): (usize, usize),
    bol: bool,
    room: usize,
    buf: &mut Vec<f64>,
) -> Chunk {
    // A local vector (moved back at the end): pushes through `&mut` would
    // reload its length and pointer at every value.
    let mut values = std::mem::take(buf);
    values.clear();
    let (mut found, mut lines, mut bol, mut short) = (0usize, 0usize, bol, false);
    let stop = scan_plain(&b[..e], a, e, &mut lines, &mut bol, |v, n| {
        let k = n.min(room - values.len());
        if k == 1 {
            values.push(v);
        } else if k > 0 {
            // A repeat's count is the input's: room asked for fallibly.
            if crate::mem::try_reserve(&mut values, k, "").is_ok() {
                values.resize(values.len() + k, v);
            } else {
                short = true;
            }
        }
        found = found.saturating_add(n);
    });
    *buf = values;
    Chunk {
        found,
        stop,
        lines,
        bol,
        short,
    }
}

/// Appends the first `counts[i]` values of each `bufs[i]` to `out`, the
/// chunks copied in parallel into `out`'s spare room; `false` (nothing
/// appended) when that room cannot be had.
fn append(out: &mut Vec<f64>, bufs: &[Vec<f64>], counts: &[usize]) -> bool {
    let total: usize = counts.iter().sum();
    if crate::mem::try_reserve(out, total, "").is_err() {
        return false;
    }
    let mut spare = &mut out.spare_capacity_mut()[..total];
    let mut parts = Vec::with_capacity(counts.len());
    for (buf, &k) in bufs.iter().zip(counts) {
        let (dst, rest) = spare.split_at_mut(k);
        parts.push((dst, &buf[..k]));
        spare = rest;
    }
    parts.into_par_iter().for_each(|(dst, src)| {
        for (d, &v) in dst.iter_mut().zip(src) {
            d.write(v);
        }
    });
    // SAFETY: the `total` slots after the length were all written above.
    unsafe { out.set_len(out.len() + total) };
    true
}

/// Drops the pages of `map` between `from` and `to` (rounded down to a
/// page; once they span 32 MiB) from this process's memory, so that the
/// file read so far stops counting in its resident set (the page cache
/// keeps them; a read there would fault them in again, the same bytes).
/// Returns the new start.
fn release(map: &MappedFile, from: usize, to: usize) -> usize {
    let to = to & !4095;
    // In steps of 32 MiB: each call costs the other threads a TLB flush.
    // Nothing in the map is read before the lexer's offset any more.
    if to >= from + (32 << 20) {
        map.release(from, to - from);
        return to;
    }
    from
}

/// Reads values into `sink` in parallel rounds while `lx` reads a mapped
/// file at a plain token boundary, more than one thread is available and
/// many values are still expected. Returns whether a round stopped early
/// (the caller stops asking after a few); the general path takes over
/// wherever this stops.
pub(super) fn values(lx: &mut Lexer, sink: &mut Sink) -> Result<bool, GrdeclError> {
    let threads = rayon::current_num_threads();
    let map = match &lx.src {
        Source::Mapped { map, .. } if threads > 1 => map.clone(),
        _ => return Ok(false),
    };
    let b: &[u8] = &map;
    let mut bufs: Vec<Vec<f64>> = Vec::new();
    let mut released = 0;
    while lx.pushed.is_none() && !lx.in_comment {
        let room = sink.expected.saturating_sub(sink.found);
        let start = lx.offset();
        let len = (threads * CHUNK).min(b.len() - start);
        if room < MIN_ROOM || len < 2 * CHUNK {
            return Ok(false);
        }
        let Some(ranges) = cut(b, start, len, threads) else {
            return Ok(true);
        };
        #[cfg(test)]
        tests::ROUNDS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        bufs.resize_with(ranges.len(), Vec::new);
        let bol0 = lx.bol;
        let chunks: Vec<Chunk> = ranges
            .par_iter()
            .zip(bufs.par_iter_mut())
            .enumerate()
            .map(|(i, (&r, buf))| scan_chunk(b, r, i > 0 || bol0, room, buf))
            .collect();
        // The chunks up to the first that stopped early, each keeping what
        // the room left.
        let (mut lines, mut bol, mut left) = (0, bol0, room);
        let mut counts = Vec::with_capacity(chunks.len());
        let mut at = ranges.last().map_or(start, |r| r.1);
        let mut early = false;
        for ((c, &(_, e)), buf) in chunks.iter().zip(&ranges).zip(&bufs) {
            let k = buf.len().min(left);
            counts.push(k);
            left -= k;
            sink.found = sink.found.saturating_add(c.found);
            sink.short |= c.short;
            lines += c.lines;
            bol = c.bol;
            if c.stop < e {
                (at, early) = (c.stop, true);
                break;
            }
        }
        if sink.short || !append(sink.out, &bufs, &counts) {
            // Out of memory: the caller reports it (`Sink::memory`).
            sink.short = true;
            return Ok(true);
        }
        lx.skip_to(at, lines, bol)?;
        released = release(&map, released, lx.offset());
        if early {
            return Ok(true);
        }
    }
    Ok(false)
}

#[cfg(test)]
mod tests {
    use std::path::Path;
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;
    use crate::io::grdecl::{read_grdecl, write_grdecl};

    /// Rounds run (all tests of this module; they take a lock to count).
    pub(super) static ROUNDS: AtomicUsize = AtomicUsize::new(0);
    static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

    /// A faulted 60×60×60 grid as GRDECL text (about 15 MB: mapped, and
    /// ZCORN long enough for several rounds).
    fn base_text() -> String {
        let g = crate::generate::faulted([60, 60, 60], 2, 7);
        let mut out = Vec::new();
        write_grdecl(&mut out, &g).unwrap();
        String::from_utf8(out).unwrap()
    }

    /// A comparable image of a read: every array's bits, or the error.
    fn image(r: Result<GrdeclDeck, GrdeclError>) -> Result<Vec<u64>, String> {
        let d = r.map_err(|e| e.to_string())?;
        let g = &d.grid;
        let mut v: Vec<u64> = g.dims.iter().map(|&n| n as u64).collect();
        v.extend(g.coord.iter().chain(&g.zcorn).map(|x| x.to_bits()));
        v.extend(g.actnum.iter().flatten().map(|&a| a as u64));
        for p in &g.properties {
            v.push(p.values.len() as u64);
            v.extend(p.values.iter().map(|x| x.to_bits()));
        }
        v.push(d.bytes);
        v.push(d.skipped.len() as u64);
        Ok(v)
    }

    /// Reads `text` (written to a file) on 1 and on 3 threads: the same
    /// image; returns it and the rounds the 3-thread read ran.
    fn same_on_threads(text: &str, name: &str) -> (Result<Vec<u64>, String>, usize) {
        let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
        let dir = std::env::temp_dir().join(format!("ss-grdecl-par-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("{name}.grdecl"));
        std::fs::write(&path, text).unwrap();
        let read = |n: usize, p: &Path| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            pool.install(|| image(read_grdecl(p)))
        };
        let one = read(1, &path);
        let before = ROUNDS.load(Ordering::Relaxed);
        let three = read(3, &path);
        let rounds = ROUNDS.load(Ordering::Relaxed) - before;
        std::fs::remove_file(&path).unwrap();
        match (&one, &three) {
            (Ok(a), Ok(b)) => assert!(a == b, "{name}: arrays differ between 1 and 3 threads"),
            _ => assert_eq!(one, three, "{name}"),
        }
        (one, rounds)
    }

    /// ZCORN's data: from after its keyword line to its `/`.
    fn zcorn_range(t: &str) -> (usize, usize) {
        let a = t.find("ZCORN\n").unwrap() + 6;
        (a, a + t[a..].find('/').unwrap())
    }

    /// `t` with `what` inserted at the line start nearest after each
    /// fraction of ZCORN's data.
    fn insert_at(t: &str, fracs: &[f64], what: &str) -> String {
        let (a, e) = zcorn_range(t);
        let mut at: Vec<usize> = fracs
            .iter()
            .map(|f| {
                let x = a + ((e - a) as f64 * f) as usize;
                x + t[x..].find('\n').unwrap() + 1
            })
            .collect();
        at.sort();
        let mut out = String::with_capacity(t.len() + what.len() * at.len());
        let mut prev = 0;
        for x in at {
            out.push_str(&t[prev..x]);
            out.push_str(what);
            prev = x;
        }
        out.push_str(&t[prev..]);
        out
    }

    #[test]
    fn plain_text_is_read_in_rounds_and_equals_one_thread() {
        let t = base_text();
        assert!(t.len() as u64 > MAP_AT_LEAST);
        let (r, rounds) = same_on_threads(&t, "plain");
        assert!(r.is_ok(), "{r:?}");
        assert!(rounds >= 2, "{rounds} rounds");
    }

    #[test]
    fn comments_crlf_and_attached_slash_equal_one_thread() {
        let t = base_text();
        let fr = [0.05, 0.31, 0.32, 0.55, 0.9];
        let c = insert_at(&t, &fr, "-- a comment / with a slash 1 2 3\n");
        let (r, rounds) = same_on_threads(&c, "comments");
        assert!(r.is_ok() && rounds >= 2, "{rounds}");
        let c = insert_at(&t, &fr, "1*1612.5 2*1612.5 -- trailing / comment\n");
        assert!(same_on_threads(&c, "trailing").0.is_err(), "count off");
        let crlf = t.replace('\n', "\r\n");
        assert!(same_on_threads(&crlf, "crlf").0.is_ok());
        let (a, e) = zcorn_range(&t);
        let tight = format!("{}{}/{}", &t[..a], t[a..e].trim_end(), &t[e + 1..]);
        assert!(same_on_threads(&tight, "tight").0.is_ok());
    }

    #[test]
    fn errors_name_the_same_line_on_any_thread_count() {
        let t = base_text();
        for (name, what) in [
            ("word", "abc\n"),
            ("default", "3*\n"),
            ("nan", "1 nan 2\n"),
            ("keyword", "ACTNUM\n"),
            ("quote", "'x'\n"),
        ] {
            let r = same_on_threads(&insert_at(&t, &[0.7], what), name).0;
            let e = r.expect_err(name);
            assert!(e.contains(":"), "{e}");
        }
        // One value too few and one too many.
        let (a, e) = zcorn_range(&t);
        let last = a + t[a..e].trim_end().rfind(' ').unwrap();
        let fewer = format!("{}{}", &t[..last], &t[e..]);
        let e1 = same_on_threads(&fewer, "fewer").0.unwrap_err();
        assert!(e1.contains("expected"), "{e1}");
        let more = insert_at(&t, &[0.5], "1600\n");
        let e2 = same_on_threads(&more, "more").0.unwrap_err();
        assert!(e2.contains("expected"), "{e2}");
    }

    #[test]
    fn long_lines_are_left_to_the_serial_path() {
        let t = base_text();
        let (a, e) = zcorn_range(&t);
        // ZCORN on lines of about 200 kB.
        let mut z = String::with_capacity(e - a);
        for (i, line) in t[a..e].lines().enumerate() {
            z.push_str(line);
            z.push(if i % 20_000 == 19_999 { '\n' } else { ' ' });
        }
        let long = format!("{}{}\n{}", &t[..a], z, &t[e..]);
        let (r, _) = same_on_threads(&long, "long");
        assert!(r.is_ok(), "{r:?}");
    }
}
