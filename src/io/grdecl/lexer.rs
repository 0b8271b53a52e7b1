//! The streaming tokenizer over a fixed window: tokens, comments, quotes, `N*v` repeats, line numbers.

use std::sync::Arc;

use crate::io::mapped::MappedFile;

use super::*;
use crate::io::number::parse_prefix;

// ---------------------------------------------------------------------------
// Lexer

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Slash,
    Word,
    Quoted,
    Eof,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Tok {
    pub(super) kind: Kind,
    pub(super) start: usize,
    pub(super) len: usize,
    pub(super) line: usize,
    /// Starts in the first column of its line.
    pub(super) col0: bool,
}

/// Where a [`Lexer`]'s bytes come from.
pub(super) enum Source<'r> {
    /// A stream, read window by window.
    Reader(Box<dyn Read + 'r>),
    /// A memory-mapped file; `at` is the offset of the window's end. The
    /// parallel path ([`super::parallel`]) reads ahead of the window here.
    Mapped { map: Arc<MappedFile>, at: usize },
}

pub(super) struct Lexer<'r> {
    pub(super) src: Source<'r>,
    pub(super) buf: Vec<u8>,
    pub(super) pos: usize,
    pub(super) end: usize,
    pub(super) eof: bool,
    pub(super) line: usize,
    pub(super) bol: bool,
    pub(super) in_comment: bool,
    pub(super) pushed: Option<Tok>,
    pub(super) file: PathBuf,
    pub(super) bytes: u64,
    /// The input's length when known.
    pub(super) len: Option<u64>,
}

impl<'r> Lexer<'r> {
    /// Capacity to reserve for an array of `n` values before they are read:
    /// `n`, but never more values than the input could spell out plainly
    /// (two bytes each), so that a header alone (SPECGRID, DIMENS) never
    /// costs more memory than the file's size. Repeats (`N*v`) grow the
    /// array as their data arrives.
    pub(super) fn reserve_hint(&self, n: usize) -> usize {
        let most = self.len.map_or(1 << 20, |l| (l / 2) as usize + 1024);
        n.min(most)
    }

    /// An empty array with room for [`Lexer::reserve_hint`]`(n)` values
    /// of keyword `kw`, or an error naming the file, the keyword and the
    /// bytes when the memory is not there.
    pub(super) fn reserve_values(&self, n: usize, kw: &str) -> Result<Vec<f64>, GrdeclError> {
        crate::mem::try_vec(self.reserve_hint(n), kw).map_err(|e| GrdeclError::Io {
            file: self.file.clone(),
            source: e.into(),
        })
    }

    /// A lexer over `r`; `len` is the input's length when known (a file), so
    /// that a small file gets a window of its size rather than [`WINDOW`]
    /// zeroed bytes (decks include many small files).
    pub(super) fn new(r: Box<dyn Read + 'r>, file: PathBuf, len: Option<u64>) -> Self {
        Lexer::over(Source::Reader(r), file, len)
    }

    /// [`Lexer::new`] over any source.
    fn over(src: Source<'r>, file: PathBuf, len: Option<u64>) -> Self {
        let size = len.map_or(WINDOW, |n| {
            usize::try_from(n.saturating_add(1))
                .unwrap_or(WINDOW)
                .clamp(2 * MAX_TOKEN, WINDOW)
        });
        Lexer {
            src,
            buf: vec![0; size],
            pos: 0,
            end: 0,
            eof: false,
            line: 1,
            bol: true,
            in_comment: false,
            pushed: None,
            file,
            bytes: 0,
            len,
        }
    }

    /// A lexer over the file `f` named `file`: memory-mapped when it holds
    /// at least [`MAP_AT_LEAST`] bytes and more than one thread can parse
    /// its big keywords, else read as a stream (one thread reads a stream
    /// faster than it faults in a map's pages: f200, 207 MB, 0.44 s against
    /// 0.46 s).
    pub(super) fn open(f: File, file: PathBuf) -> Lexer<'static> {
        let len = f.metadata().ok().map(|m| m.len());
        if len.is_some_and(|n| n >= MAP_AT_LEAST) && rayon::current_num_threads() > 1 {
            // A truncation while it is read gives zeros, reported by
            // [`Lexer::settle`] (`io::mapped`).
            if let Some(map) = f.try_clone().ok().and_then(MappedFile::map) {
                let map = Arc::new(map);
                return Lexer::over(Source::Mapped { map, at: 0 }, file, len);
            }
        }
        Lexer::new(Box::new(f), file, len)
    }

    /// Returns `r`, the outcome of reading this lexer's input, unless the
    /// input is a map whose file was truncated (or failed a page read)
    /// meanwhile: then an I/O error naming the file, whatever `r` was.
    pub(super) fn settle<T>(&self, r: Result<T, GrdeclError>) -> Result<T, GrdeclError> {
        match &self.src {
            Source::Mapped { map, .. } => map.settle(r, |source| GrdeclError::Io {
                file: self.file.clone(),
                source,
            }),
            Source::Reader(_) => r,
        }
    }

    /// Offset in the input of the next unread byte (`pos`).
    pub(super) fn offset(&self) -> usize {
        let at = match &self.src {
            Source::Mapped { at, .. } => *at,
            Source::Reader(_) => self.bytes as usize,
        };
        at - (self.end - self.pos)
    }

    /// A mapped input moves on to offset `x` (at least [`Lexer::offset`]),
    /// with `lines` more lines and `bol` at `x`; the bytes skipped count
    /// as read.
    pub(super) fn skip_to(&mut self, x: usize, lines: usize, bol: bool) -> Result<(), GrdeclError> {
        let here = self.offset();
        debug_assert!(x >= here && self.pushed.is_none());
        self.line += lines;
        self.bol = bol;
        if let Source::Mapped { at, .. } = &mut self.src
            && x > *at
        {
            self.bytes += (x - *at) as u64;
            *at = x;
            self.pos = 0;
            self.end = 0;
            self.eof = false;
            return self.refill();
        }
        self.pos += x - here;
        Ok(())
    }

    pub(super) fn refill(&mut self) -> Result<(), GrdeclError> {
        if self.eof {
            return Ok(());
        }
        self.buf.copy_within(self.pos..self.end, 0);
        self.end -= self.pos;
        self.pos = 0;
        let r = match &mut self.src {
            Source::Reader(r) => r,
            Source::Mapped { map, at } => {
                let n = (self.buf.len() - self.end).min(map.len() - *at);
                self.buf[self.end..self.end + n].copy_from_slice(&map[*at..*at + n]);
                *at += n;
                self.end += n;
                self.bytes += n as u64;
                self.eof = *at == map.len();
                return Ok(());
            }
        };
        while self.end < self.buf.len() {
            match r.read(&mut self.buf[self.end..]) {
                Ok(0) => {
                    self.eof = true;
                    break;
                }
                Ok(n) => {
                    self.end += n;
                    self.bytes += n as u64;
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(GrdeclError::Io {
                        file: self.file.clone(),
                        source: e,
                    });
                }
            }
        }
        Ok(())
    }

    pub(super) fn text(&self, t: &Tok) -> &[u8] {
        &self.buf[t.start..t.start + t.len]
    }

    pub(super) fn text_string(&self, t: &Tok) -> String {
        match t.kind {
            Kind::Eof => "end of file".into(),
            Kind::Slash => "/".into(),
            _ => String::from_utf8_lossy(self.text(t)).into_owned(),
        }
    }

    /// The repeat count `n` of token `t` (`n*...`) in keyword `kw`.
    pub(super) fn repeat(&self, t: &Tok, kw: &str, n: &[u8]) -> Result<usize, GrdeclError> {
        repeat_count(n).map_err(|why| GrdeclError::BadRepeat {
            file: self.file.clone(),
            line: t.line,
            keyword: kw.into(),
            token: self.text_string(t),
            why,
        })
    }

    pub(super) fn push_back(&mut self, t: Tok) {
        self.pushed = Some(t);
    }

    pub(super) fn peek(&mut self) -> Result<Tok, GrdeclError> {
        let t = self.next()?;
        self.pushed = Some(t);
        Ok(t)
    }

    pub(super) fn bad(&self, line: usize, keyword: &str, why: impl Into<String>) -> GrdeclError {
        GrdeclError::BadRecord {
            file: self.file.clone(),
            line,
            keyword: keyword.into(),
            why: why.into(),
        }
    }

    /// Plain numbers and `N*v` repeats straight from the window into
    /// `sink`, until anything else (a default `N*`, a comment, `/`, a word,
    /// the window's margin): then the general path takes over. Same results as `next` + `parse_number`.
    #[inline]
    pub(super) fn fast_values(&mut self, sink: &mut Sink) {
        if self.pushed.is_some() || self.in_comment {
            return;
        }
        let end = self.end;
        let limit = if self.eof {
            end
        } else {
            end.saturating_sub(MAX_TOKEN)
        };
        let (mut line, mut bol) = (self.line, self.bol);
        self.pos = scan_plain(
            &self.buf[..end],
            self.pos,
            limit,
            &mut line,
            &mut bol,
            |v, n| sink.push(v, n),
        );
        self.line = line;
        self.bol = bol;
    }

    /// The next token. Tokens stay valid until the next call to `next`.
    pub(super) fn next(&mut self) -> Result<Tok, GrdeclError> {
        if let Some(t) = self.pushed.take() {
            return Ok(t);
        }
        loop {
            if self.end - self.pos < MAX_TOKEN && !self.eof {
                self.refill()?;
            }
            let end = self.end;
            let b = &self.buf[..end];
            let mut p = self.pos;
            if self.in_comment {
                while p < end && b[p] != b'\n' {
                    p += 1;
                }
                self.pos = p;
                if p == end {
                    if self.eof {
                        self.in_comment = false;
                        continue;
                    }
                    continue;
                }
                self.in_comment = false;
            }
            while p < end {
                let c = b[p];
                if c == b'\n' {
                    self.line += 1;
                    self.bol = true;
                } else if c <= b' ' {
                    self.bol = false;
                } else {
                    break;
                }
                p += 1;
            }
            self.pos = p;
            if p == end {
                if self.eof {
                    return Ok(Tok {
                        kind: Kind::Eof,
                        start: p,
                        len: 0,
                        line: self.line,
                        col0: self.bol,
                    });
                }
                continue;
            }
            let c = b[p];
            if c == b'-' && p + 1 < end && b[p + 1] == b'-' {
                self.in_comment = true;
                self.bol = false;
                continue;
            }
            let col0 = self.bol;
            self.bol = false;
            let line = self.line;
            if c == b'/' {
                self.pos = p + 1;
                return Ok(Tok {
                    kind: Kind::Slash,
                    start: p,
                    len: 1,
                    line,
                    col0,
                });
            }
            if c == b'\'' || c == b'"' {
                let Some(q) = b[p + 1..].iter().position(|&x| x == c || x == b'\n') else {
                    return Err(self.bad(line, "", "unterminated quoted string"));
                };
                if b[p + 1 + q] != c {
                    return Err(self.bad(line, "", "unterminated quoted string"));
                }
                self.pos = p + 2 + q;
                return Ok(Tok {
                    kind: Kind::Quoted,
                    start: p + 1,
                    len: q,
                    line,
                    col0,
                });
            }
            let mut q = p;
            while q < end {
                let x = b[q];
                if x <= b' ' || x == b'/' {
                    break;
                }
                q += 1;
            }
            if q == end && !self.eof {
                return Err(self.bad(line, "", format!("token longer than {MAX_TOKEN} bytes")));
            }
            self.pos = q;
            return Ok(Tok {
                kind: Kind::Word,
                start: p,
                len: q - p,
                line,
                col0,
            });
        }
    }
}

/// The fast path over `b` from `p`: plain numbers and `N*v` repeats (`N` a
/// plain positive integer as `repeat_count` takes it, `v` a plain number)
/// go to `push(value, count)`, whitespace counts lines (`line`) and tracks
/// the start of a line (`bol`), until anything else (a default `N*`, a
/// comment, `/`, a word) or until no token starts before `limit`. Returns
/// where it stopped. A token may end past `limit`, never past `b`'s end.
#[inline(always)]
pub(super) fn scan_plain(
    b: &[u8],
    mut p: usize,
    limit: usize,
    line: &mut usize,
    bol: &mut bool,
    mut push: impl FnMut(f64, usize),
) -> usize {
    let end = b.len();
    while p < limit {
        let c = b[p];
        if c <= b' ' {
            if c == b'\n' {
                *line += 1;
                *bol = true;
            } else {
                *bol = false;
            }
            p += 1;
            continue;
        }
        let Some((mut v, len)) = parse_prefix::<true>(&b[p..]) else {
            break;
        };
        let mut q = p + len;
        let mut count = 1;
        if q < end && b[q] == b'*' {
            let n = &b[p..q];
            if n.len() > 12 || !n.iter().all(u8::is_ascii_digit) {
                break;
            }
            count = n.iter().fold(0usize, |a, &c| a * 10 + (c - b'0') as usize);
            let Some((w, l)) = parse_prefix::<true>(&b[q + 1..]) else {
                break;
            };
            if count == 0 {
                break;
            }
            v = w;
            q += 1 + l;
        }
        if q < end && b[q] > b' ' && b[q] != b'/' {
            break;
        }
        push(v, count);
        *bol = false;
        p = q;
    }
    p
}

/// Whether `t` can be a keyword: up to 8 letters, digits, `_`, `-` or `+`,
/// starting with a letter.
pub(super) fn is_keyword_like(t: &[u8]) -> bool {
    !t.is_empty()
        && t.len() <= 8
        && t[0].is_ascii_alphabetic()
        && t.iter()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, b'_' | b'-' | b'+'))
}

/// A numeric sink with an expected count.
pub(super) struct Sink<'a> {
    pub(super) out: &'a mut Vec<f64>,
    pub(super) expected: usize,
    pub(super) found: usize,
    /// A repeat's values did not fit in memory (then not kept; see
    /// [`Sink::memory`]).
    pub(super) short: bool,
}

impl Sink<'_> {
    #[inline(always)]
    pub(super) fn push(&mut self, v: f64, n: usize) {
        let room = self.expected.saturating_sub(self.found);
        let k = n.min(room);
        if k == 1 {
            self.out.push(v);
        } else if k > 0 {
            self.repeat(v, k);
        }
        self.found = self.found.saturating_add(n);
    }

    /// `k` copies of `v`, the room asked for fallibly (a repeat's count is
    /// the input's: `800000000*1`).
    #[inline(never)]
    fn repeat(&mut self, v: f64, k: usize) {
        if crate::mem::try_reserve(self.out, k, "").is_err() {
            self.short = true;
        } else {
            self.out.resize(self.out.len() + k, v);
        }
    }

    /// `Ok`, or, when a repeat did not fit in memory, an error naming the
    /// file, the keyword `kw` and the bytes of its `expected` values.
    pub(super) fn memory(&self, lx: &Lexer, kw: &str) -> Result<(), GrdeclError> {
        if !self.short {
            return Ok(());
        }
        Err(GrdeclError::Io {
            file: lx.file.clone(),
            source: crate::mem::AllocError::of::<f64>(self.expected, kw).into(),
        })
    }
}

/// The repeat count `N` of an `N*value` item: a plain positive integer.
pub(super) fn repeat_count(s: &[u8]) -> Result<usize, &'static str> {
    if s.is_empty() {
        return Err("the repeat count is missing");
    }
    if !s.iter().all(|c| c.is_ascii_digit()) {
        return Err("the repeat count is not a positive integer");
    }
    if s.len() > 12 {
        return Err("the repeat count is too large");
    }
    let r = s.iter().fold(0usize, |a, &c| a * 10 + (c - b'0') as usize);
    if r == 0 {
        return Err("the repeat count is zero");
    }
    Ok(r)
}
