//! The XML scan: elements, attributes, text ranges and the appended data
//! section, without a DOM library.

use super::VtkReadError;
use crate::io::vtk_read::common::is_ws;

/// An element of the (pre-`AppendedData`) XML tree.
pub(super) struct Elem<'a> {
    pub(super) name: &'a str,
    pub(super) attrs: Vec<(&'a str, String)>,
    pub(super) children: Vec<usize>,
    /// Byte ranges of the element's own (non-blank) text nodes.
    pub(super) text: Vec<(usize, usize)>,
}

impl Elem<'_> {
    pub(super) fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// The appended data section: `start` is just after the `_` marker.
#[derive(Clone, Copy)]
pub(super) struct Appended {
    pub(super) base64: bool,
    pub(super) start: usize,
    pub(super) end: usize,
}

pub(super) struct Doc<'a> {
    pub(super) b: &'a [u8],
    pub(super) elems: Vec<Elem<'a>>,
    pub(super) root: usize,
    pub(super) appended: Option<Appended>,
}

pub(super) fn find(b: &[u8], from: usize, pat: &[u8]) -> Option<usize> {
    let hay = b.get(from..)?;
    if pat.len() == 1 {
        return hay.iter().position(|&c| c == pat[0]).map(|p| p + from);
    }
    hay.windows(pat.len())
        .position(|w| w == pat)
        .map(|p| p + from)
}

pub(super) fn decode_entities(raw: &[u8]) -> String {
    let s = String::from_utf8_lossy(raw);
    if !s.contains('&') {
        return s.into_owned();
    }
    let mut out = String::with_capacity(s.len());
    let mut rest: &str = &s;
    while let Some(p) = rest.find('&') {
        out.push_str(&rest[..p]);
        let tail = &rest[p..];
        let Some(semi) = tail.find(';').filter(|&q| q <= 10) else {
            out.push('&');
            rest = &tail[1..];
            continue;
        };
        let ent = &tail[1..semi];
        let ch = match ent {
            "lt" => Some('<'),
            "gt" => Some('>'),
            "amp" => Some('&'),
            "quot" => Some('"'),
            "apos" => Some('\''),
            _ => ent.strip_prefix('#').and_then(|n| {
                let v = match n.strip_prefix('x').or_else(|| n.strip_prefix('X')) {
                    Some(h) => u32::from_str_radix(h, 16).ok(),
                    None => n.parse().ok(),
                };
                v.and_then(char::from_u32)
            }),
        };
        match ch {
            Some(c) => {
                out.push(c);
                rest = &tail[semi + 1..];
            }
            None => {
                out.push('&');
                rest = &tail[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// Scans the XML markup up to (and including) the `<AppendedData>` start
/// tag; the bytes after it are raw data, not XML.
pub(super) fn scan<'a>(b: &'a [u8], file: &str) -> Result<Doc<'a>, VtkReadError> {
    let err = |element: &str, msg: String| VtkReadError::Xml {
        file: file.to_string(),
        element: element.to_string(),
        msg,
    };
    let mut elems: Vec<Elem<'a>> = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    let mut roots = Vec::new();
    let mut appended = None;
    let mut i = 0;
    while i < b.len() {
        if b[i] != b'<' {
            let end = find(b, i, b"<").unwrap_or(b.len());
            if let Some(&top) = stack.last()
                && b[i..end].iter().any(|&c| !is_ws(c))
            {
                elems[top].text.push((i, end));
            }
            i = end;
            continue;
        }
        let rest = &b[i..];
        let skip_to = |pat: &[u8], what: &str| {
            find(b, i + 1, pat)
                .map(|p| p + pat.len())
                .ok_or_else(|| err("document", format!("unterminated {what}")))
        };
        if rest.starts_with(b"<?") {
            i = skip_to(b"?>", "processing instruction")?;
        } else if rest.starts_with(b"<!--") {
            i = skip_to(b"-->", "comment")?;
        } else if rest.starts_with(b"<![CDATA[") {
            let e = find(b, i + 9, b"]]>")
                .ok_or_else(|| err("document", "unterminated CDATA section".into()))?;
            if let Some(&top) = stack.last() {
                elems[top].text.push((i + 9, e));
            }
            i = e + 3;
        } else if rest.starts_with(b"<!") {
            i = skip_to(b">", "declaration")?;
        } else if rest.starts_with(b"</") {
            let e =
                find(b, i, b">").ok_or_else(|| err("document", "unterminated end tag".into()))?;
            let name = String::from_utf8_lossy(b[i + 2..e].trim_ascii());
            let Some(top) = stack.pop() else {
                return Err(err(
                    &format!("</{name}>"),
                    "end tag without a start tag".into(),
                ));
            };
            if elems[top].name != name {
                return Err(err(
                    &format!("<{}>", elems[top].name),
                    format!("closed by </{name}> (mismatched or truncated markup)"),
                ));
            }
            i = e + 1;
        } else {
            let (elem, self_closing, next) = start_tag(b, i + 1, file)?;
            let idx = elems.len();
            match stack.last() {
                Some(&p) => elems[p].children.push(idx),
                None => roots.push(idx),
            }
            let is_appended = elem.name == "AppendedData";
            elems.push(elem);
            i = next;
            if is_appended {
                let e = &elems[idx];
                let base64 = match e.attr("encoding").unwrap_or("raw") {
                    "raw" => false,
                    "base64" => true,
                    other => {
                        return Err(VtkReadError::Unsupported {
                            file: file.to_string(),
                            what: format!("<AppendedData> encoding '{other}'"),
                        });
                    }
                };
                let us = (i..b.len()).find(|&k| !is_ws(b[k]));
                let Some(us) = us.filter(|&k| b[k] == b'_') else {
                    return Err(err("<AppendedData>", "data does not start with '_'".into()));
                };
                let start = us + 1;
                let close = b"</AppendedData>";
                let end = b
                    .get(start..)
                    .and_then(|tail| tail.windows(close.len()).rposition(|w| w == close))
                    .map_or(b.len(), |p| p + start);
                appended = Some(Appended { base64, start, end });
                break;
            }
            if !self_closing {
                stack.push(idx);
            }
        }
    }
    if appended.is_none()
        && let Some(&top) = stack.last()
    {
        return Err(err(
            &format!("<{}>", elems[top].name),
            "not closed (truncated file?)".into(),
        ));
    }
    let root = *roots
        .first()
        .ok_or_else(|| err("document", "no root element".into()))?;
    Ok(Doc {
        b,
        elems,
        root,
        appended,
    })
}

/// Parses a start tag whose name begins at `j`. Returns the element, whether
/// it is self-closing and the position after `>`.
pub(super) fn start_tag<'a>(
    b: &'a [u8],
    mut j: usize,
    file: &str,
) -> Result<(Elem<'a>, bool, usize), VtkReadError> {
    let err = |element: &str, msg: &str| VtkReadError::Xml {
        file: file.to_string(),
        element: element.to_string(),
        msg: msg.to_string(),
    };
    let ns = j;
    while b
        .get(j)
        .is_some_and(|&c| !is_ws(c) && c != b'/' && c != b'>')
    {
        j += 1;
    }
    let name =
        std::str::from_utf8(&b[ns..j]).map_err(|_| err("document", "tag name is not UTF-8"))?;
    if name.is_empty() {
        return Err(err("document", "empty tag name"));
    }
    let tag = format!("<{name}>");
    let mut attrs = Vec::new();
    loop {
        while b.get(j).is_some_and(|&c| is_ws(c)) {
            j += 1;
        }
        match b.get(j) {
            None => return Err(err(&tag, "unterminated start tag")),
            Some(b'>') => {
                return Ok((
                    Elem {
                        name,
                        attrs,
                        children: Vec::new(),
                        text: Vec::new(),
                    },
                    false,
                    j + 1,
                ));
            }
            Some(b'/') if b.get(j + 1) == Some(&b'>') => {
                return Ok((
                    Elem {
                        name,
                        attrs,
                        children: Vec::new(),
                        text: Vec::new(),
                    },
                    true,
                    j + 2,
                ));
            }
            Some(_) => {}
        }
        let ks = j;
        while b
            .get(j)
            .is_some_and(|&c| !is_ws(c) && c != b'=' && c != b'>' && c != b'/')
        {
            j += 1;
        }
        let key =
            std::str::from_utf8(&b[ks..j]).map_err(|_| err(&tag, "attribute name is not UTF-8"))?;
        if key.is_empty() {
            return Err(err(&tag, "malformed attribute"));
        }
        while b.get(j).is_some_and(|&c| is_ws(c)) {
            j += 1;
        }
        if b.get(j) != Some(&b'=') {
            return Err(err(&tag, &format!("attribute '{key}' without a value")));
        }
        j += 1;
        while b.get(j).is_some_and(|&c| is_ws(c)) {
            j += 1;
        }
        let q = match b.get(j) {
            Some(&q @ (b'"' | b'\'')) => q,
            _ => return Err(err(&tag, &format!("attribute '{key}' value is not quoted"))),
        };
        let ve = find(b, j + 1, &[q])
            .ok_or_else(|| err(&tag, &format!("unterminated value of attribute '{key}'")))?;
        attrs.push((key, decode_entities(&b[j + 1..ve])));
        j = ve + 1;
    }
}
