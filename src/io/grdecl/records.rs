//! Reading one keyword's records: values with repeats and defaults, small records, strings, operator boxes; count errors.

use super::lexer::*;
use super::*;

/// Splits a value token into `(repeat, value)`; value `None` = default.
/// Returns `None` when the token is malformed (the caller reports why).
pub(super) fn value_token(s: &[u8]) -> Option<(usize, Option<f64>)> {
    match s.iter().position(|&c| c == b'*') {
        None => parse_number(s).map(|v| (1, Some(v))),
        Some(k) => {
            let r = repeat_count(&s[..k]).ok()?;
            if k + 1 == s.len() {
                Some((r, None))
            } else {
                parse_number(&s[k + 1..]).map(|v| (r, Some(v)))
            }
        }
    }
}

/// Reads a numeric record of exactly `expected` values into `out`.
pub(super) fn read_values(
    lx: &mut Lexer,
    kw: &str,
    kw_line: usize,
    expected: usize,
    out: &mut Vec<f64>,
    default: Option<f64>,
) -> Result<(), GrdeclError> {
    let mut sink = Sink {
        out,
        expected,
        found: 0,
        short: false,
    };
    // Rounds of the parallel path that stopped early (comments between
    // the values, say): after a few, the serial path reads the rest.
    let mut early = 0;
    loop {
        if early < 3 && super::parallel::values(lx, &mut sink)? {
            early += 1;
        }
        lx.fast_values(&mut sink);
        sink.memory(lx, kw)?;
        let t = lx.next()?;
        match t.kind {
            Kind::Slash => break,
            Kind::Eof => {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line: t.line,
                    keyword: kw.into(),
                    expected,
                    found: sink.found,
                    next: "end of file".into(),
                });
            }
            Kind::Quoted => {
                return Err(GrdeclError::NotNumeric {
                    file: lx.file.clone(),
                    line: t.line,
                    keyword: kw.into(),
                    token: lx.text_string(&t),
                });
            }
            Kind::Word => {}
        }
        let s = lx.text(&t);
        // Fast path: a plain number.
        if let Some(v) = parse_number(s) {
            if !v.is_finite() {
                return Err(not_finite(lx, &t, kw));
            }
            sink.push(v, 1);
            continue;
        }
        let Some(k) = s.iter().position(|&c| c == b'*') else {
            if t.col0 && is_keyword_like(s) {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line: t.line,
                    keyword: kw.into(),
                    expected,
                    found: sink.found,
                    next: format!("keyword {}", lx.text_string(&t)),
                });
            }
            return Err(GrdeclError::NotNumeric {
                file: lx.file.clone(),
                line: t.line,
                keyword: kw.into(),
                token: lx.text_string(&t),
            });
        };
        let r = lx.repeat(&t, kw, &s[..k])?;
        let v = if k + 1 == s.len() {
            match default {
                Some(d) => d,
                None => {
                    return Err(GrdeclError::BadRepeat {
                        file: lx.file.clone(),
                        line: t.line,
                        keyword: kw.into(),
                        token: lx.text_string(&t),
                        why: "this keyword has no default value",
                    });
                }
            }
        } else {
            match parse_number(&s[k + 1..]) {
                Some(v) if v.is_finite() => v,
                Some(_) => return Err(not_finite(lx, &t, kw)),
                None => {
                    return Err(GrdeclError::NotNumeric {
                        file: lx.file.clone(),
                        line: t.line,
                        keyword: kw.into(),
                        token: lx.text_string(&t),
                    });
                }
            }
        };
        sink.push(v, r);
    }
    if sink.found != expected {
        return Err(GrdeclError::CountMismatch {
            file: lx.file.clone(),
            line: kw_line,
            keyword: kw.into(),
            expected,
            found: sink.found,
        });
    }
    Ok(())
}

pub(super) fn not_finite(lx: &Lexer, t: &Tok, kw: &str) -> GrdeclError {
    GrdeclError::NotFinite {
        file: lx.file.clone(),
        line: t.line,
        keyword: kw.into(),
        token: lx.text_string(t),
    }
}

/// Reads a short record of at least `min` and at most `max` items, where
/// `N*` defaults give `None`.
pub(super) fn read_small(
    lx: &mut Lexer,
    kw: &str,
    line: usize,
    min: usize,
    max: usize,
) -> Result<Vec<Option<f64>>, GrdeclError> {
    let mut v: Vec<Option<f64>> = Vec::new();
    loop {
        let t = lx.next()?;
        match t.kind {
            Kind::Slash => break,
            Kind::Eof => {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line: t.line,
                    keyword: kw.into(),
                    expected: min,
                    found: v.len(),
                    next: "end of file".into(),
                });
            }
            Kind::Quoted => v.push(None),
            Kind::Word => {
                let s = lx.text(&t);
                if v.len() >= min {
                    // Optional trailing items: SPECGRID's COORDTYPE is 'F' or 'T'.
                    match s {
                        b"F" | b"f" => {
                            v.push(Some(0.0));
                            continue;
                        }
                        b"T" | b"t" => {
                            v.push(Some(1.0));
                            continue;
                        }
                        _ => {}
                    }
                }
                match s.iter().position(|&c| c == b'*') {
                    Some(k) => {
                        let r = lx.repeat(&t, kw, &s[..k])?;
                        let val = if k + 1 == s.len() {
                            None
                        } else {
                            Some(parse_number(&s[k + 1..]).ok_or_else(|| {
                                GrdeclError::NotNumeric {
                                    file: lx.file.clone(),
                                    line: t.line,
                                    keyword: kw.into(),
                                    token: lx.text_string(&t),
                                }
                            })?)
                        };
                        if v.len() + r > max {
                            return Err(count_err(lx, kw, line, max, v.len() + r));
                        }
                        v.resize(v.len() + r, val);
                    }
                    None => {
                        let x = parse_number(s).ok_or_else(|| GrdeclError::NotNumeric {
                            file: lx.file.clone(),
                            line: t.line,
                            keyword: kw.into(),
                            token: lx.text_string(&t),
                        })?;
                        if !x.is_finite() {
                            return Err(not_finite(lx, &t, kw));
                        }
                        v.push(Some(x));
                    }
                }
                if v.len() > max {
                    return Err(count_err(lx, kw, line, max, v.len()));
                }
            }
        }
    }
    if v.len() < min {
        return Err(count_err(lx, kw, line, min, v.len()));
    }
    Ok(v)
}

/// One record of an operator keyword up to its `/` (`N*` expanded to `N`
/// defaulted items), and the record's line; the rest of the `/`'s line is
/// a comment. `None` for the empty record that ends the keyword.
#[allow(clippy::type_complexity)]
pub(super) fn read_record(
    lx: &mut Lexer,
    kw: &str,
    line: usize,
) -> Result<Option<(Vec<Option<String>>, usize)>, GrdeclError> {
    let mut items = Vec::new();
    let mut first = None;
    loop {
        let t = lx.next()?;
        match t.kind {
            Kind::Eof => {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line: first.unwrap_or(line),
                    keyword: kw.into(),
                    expected: 1,
                    found: items.len(),
                    next: "end of file before the closing '/'".into(),
                });
            }
            Kind::Slash => {
                let Some(l) = first else { return Ok(None) };
                loop {
                    let u = lx.next()?;
                    if u.kind == Kind::Eof || u.line != t.line {
                        lx.push_back(u);
                        break;
                    }
                }
                return Ok(Some((items, l)));
            }
            _ => {
                first.get_or_insert(t.line);
                let s = lx.text(&t);
                match s.iter().position(|&c| c == b'*') {
                    Some(k) if t.kind == Kind::Word => {
                        let r = lx.repeat(&t, kw, &s[..k])?;
                        if r > 8 {
                            return Err(lx.bad(t.line, kw, "a record has at most 8 items"));
                        }
                        let v = (k + 1 < s.len())
                            .then(|| String::from_utf8_lossy(&s[k + 1..]).into_owned());
                        items.extend(std::iter::repeat_n(v, r));
                    }
                    _ => items.push(Some(lx.text_string(&t))),
                }
            }
        }
    }
}

/// A box `[i1, i2, j1, j2, k1, k2]` (1-based, inclusive) from up to six
/// items; missing or defaulted items take `prev`'s (none: the whole grid).
pub(super) fn op_box(
    lx: &Lexer,
    kw: &str,
    line: usize,
    dims: [usize; 3],
    items: &[Option<String>],
    prev: Option<[usize; 6]>,
) -> Result<[usize; 6], GrdeclError> {
    let full = [1, dims[0], 1, dims[1], 1, dims[2]];
    let prev = prev.unwrap_or(full);
    let mut b = prev;
    for (a, item) in items.iter().enumerate() {
        if let Some(s) = item {
            let x = parse_number(s.trim().as_bytes())
                .filter(|x| x.fract() == 0.0 && *x >= 1.0)
                .ok_or_else(|| {
                    lx.bad(
                        line,
                        kw,
                        format!("box index '{s}' is not a positive integer"),
                    )
                })?;
            let dim = full[2 * (a / 2) + 1];
            if x > dim as f64 {
                let axis = ["I", "J", "K"][a / 2];
                return Err(lx.bad(
                    line,
                    kw,
                    format!(
                        "box index {s} is out of range: {axis} runs from 1 to {dim} in this grid"
                    ),
                ));
            }
            b[a] = x as usize;
        }
    }
    for (a, axis) in ["I", "J", "K"].iter().enumerate() {
        let (lo, hi) = (b[2 * a], b[2 * a + 1]);
        if lo > hi || hi > full[2 * a + 1] {
            return Err(lx.bad(
                line,
                kw,
                format!("box {axis} {lo}..{hi} is not within 1..{}", full[2 * a + 1]),
            ));
        }
    }
    Ok(b)
}

pub(super) fn count_err(
    lx: &Lexer,
    kw: &str,
    line: usize,
    expected: usize,
    found: usize,
) -> GrdeclError {
    GrdeclError::CountMismatch {
        file: lx.file.clone(),
        line,
        keyword: kw.into(),
        expected,
        found,
    }
}

/// Reads a record of strings (quoted or not) up to `/`.
pub(super) fn read_strings(
    lx: &mut Lexer,
    kw: &str,
    line: usize,
) -> Result<Vec<String>, GrdeclError> {
    let mut v = Vec::new();
    loop {
        let t = lx.next()?;
        match t.kind {
            Kind::Slash => return Ok(v),
            Kind::Eof => {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line,
                    keyword: kw.into(),
                    expected: 1,
                    found: v.len(),
                    next: "end of file".into(),
                });
            }
            _ => v.push(lx.text_string(&t)),
        }
    }
}
