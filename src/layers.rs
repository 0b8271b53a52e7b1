//! The layering of the crate, checked: every `.rs` file under `src/` belongs
//! to one layer of [`LAYERS`], and a module imports (`crate::…`, `super::…`,
//! `self::…` or a child module's path, in a `use` or inline) only from its
//! own layer or the layers below. The test reads the sources, so it needs
//! nothing built; it fails naming the file, the line and the import.
//!
//! Comments, doc links and string literals do not count; test modules do
//! (a unit test that needs a layer above belongs in `tests/`).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The layers, bottom to top, and the modules in each: paths under `src/`
/// without `.rs` (`"gpu/scene"` is `src/gpu/scene.rs` and everything under
/// `src/gpu/scene/`). A file or an import belongs to the row of the
/// longest path that contains it; a new module must be placed here.
const LAYERS: &[(&str, &[&str])] = &[
    (
        "core",
        &[
            "vec3",
            "mem",
            "cancel",
            "limits",
            "grid",
            "mesh",
            "field",
            "metacell",
            "cornerpoint",
            "generate",
            "voronoi",
            "io",
            "layers",
        ],
    ),
    (
        "structures",
        &["cellgraph", "extract", "properties", "structures"],
    ),
    ("sweep", &["sweep", "bruteforce"]),
    ("pipeline", &["pipeline", "report"]),
    (
        "gpu/compute",
        &[
            // The device and what every pass shares (context, shaders,
            // shared), and any other file directly in gpu/.
            "gpu",
            "gpu/compute",
        ],
    ),
    ("gpu/render", &["gpu/render"]),
    ("gpu/view", &["gpu/view"]),
    ("policy", &["policy"]),
    ("front ends", &["py", "cli", "main", "lib"]),
];

/// Known violations waiting for a move outside this branch: (the importing
/// module, the imported path). Each must still occur (a fixed one fails the
/// test until its row goes).
const PENDING: &[(&str, &str)] = &[];

/// The layer (index into [`LAYERS`]) of a module path (`"io/grdecl/lexer"`):
/// the row of its longest containing entry.
fn layer_of(path: &str) -> Option<usize> {
    let mut best: Option<(usize, usize)> = None;
    for (layer, (_, modules)) in LAYERS.iter().enumerate() {
        for m in *modules {
            let inside = path == *m
                || path
                    .strip_prefix(m)
                    .is_some_and(|rest| rest.starts_with('/'));
            if inside && best.is_none_or(|(len, _)| m.len() > len) {
                best = Some((m.len(), layer));
            }
        }
    }
    best.map(|(_, layer)| layer)
}

/// `src` with comments, string, byte-string and character literals blanked
/// (replaced by spaces; line breaks kept, so lines still count).
fn strip(src: &str) -> String {
    let c: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut i = 0;
    while i < c.len() {
        let at = |k: usize| c.get(k).copied().unwrap_or('\0');
        if at(i) == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if at(i) == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if at(i) == '/' && at(i + 1) == '*' {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if at(i) == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if (at(i) == 'r' || (at(i) == 'b' && at(i + 1) == 'r'))
            && (i == 0 || !ident(c[i - 1]))
            && {
                let mut k = i + if at(i) == 'b' { 2 } else { 1 };
                while at(k) == '#' {
                    k += 1;
                }
                at(k) == '"'
            }
        {
            // A raw string: r"…", r#"…"#, br"…".
            let mut k = i + if at(i) == 'b' { 2 } else { 1 };
            let mut hashes = 0;
            while at(k) == '#' {
                hashes += 1;
                k += 1;
            }
            k += 1;
            while k < c.len() && !(c[k] == '"' && (1..=hashes).all(|h| at(k + h) == '#')) {
                k += 1;
            }
            let end = (k + 1 + hashes).min(c.len());
            for &ch in &c[i..end] {
                blank(&mut out, ch);
            }
            i = end;
        } else if at(i) == '"' {
            blank(&mut out, c[i]);
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    blank(&mut out, c[i]);
                    i += 1;
                }
                if i < c.len() {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
            if i < c.len() {
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if at(i) == '\'' && (at(i + 1) == '\\' || at(i + 2) == '\'') {
            // A character literal ('x', '\n', '\u{..}'), not a lifetime.
            let mut k = i + 1;
            if at(k) == '\\' {
                k += 2;
                while k < c.len() && c[k] != '\'' {
                    k += 1;
                }
            } else {
                k += 1;
            }
            let end = (k + 1).min(c.len());
            for &ch in &c[i..end] {
                blank(&mut out, ch);
            }
            i = end;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// One import: the line it is on, the path as written and the module path
/// it names (`"io/grdecl/Lexer"`).
#[derive(Debug, PartialEq)]
struct Import {
    line: usize,
    written: String,
    target: String,
}

/// The child modules declared in `code` (`mod x;`, `mod x {`).
fn child_modules(code: &str) -> BTreeSet<&str> {
    let words: Vec<&str> = code
        .split(|ch: char| !(ch.is_alphanumeric() || ch == '_'))
        .filter(|w| !w.is_empty())
        .collect();
    words
        .windows(2)
        .filter(|w| w[0] == "mod")
        .map(|w| w[1])
        .collect()
}

/// The crate paths that the file of module `module` (`["io", "grdecl"]`)
/// uses. `src` is the file's text.
fn imports(module: &[String], src: &str) -> Vec<Import> {
    let code = strip(src);
    let b: Vec<char> = code.chars().collect();
    let is_ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let children = child_modules(&code);
    let mut out = Vec::new();
    let mut line = 1;
    // Inline modules open here: (brace depth inside, name).
    let mut inline: Vec<(usize, String)> = Vec::new();
    let mut depth = 0usize;
    let mut pending_mod: Option<String> = None;
    let mut i = 0;
    let word_at = |i: usize| -> String {
        b[i..]
            .iter()
            .take_while(|&&ch| is_ident(ch))
            .collect::<String>()
    };
    while i < b.len() {
        let ch = b[i];
        if ch == '\n' {
            line += 1;
            i += 1;
            continue;
        }
        if ch == '{' {
            depth += 1;
            if let Some(name) = pending_mod.take() {
                inline.push((depth, name));
            }
            i += 1;
            continue;
        }
        if ch == '}' {
            if inline.last().is_some_and(|(d, _)| *d == depth) {
                inline.pop();
            }
            depth = depth.saturating_sub(1);
            i += 1;
            continue;
        }
        if ch == ';' {
            pending_mod = None;
        }
        if !is_ident(ch) || (i > 0 && (is_ident(b[i - 1]) || b[i - 1] == '$')) {
            i += 1;
            continue;
        }
        let word = word_at(i);
        let here: Vec<String> = module
            .iter()
            .cloned()
            .chain(inline.iter().map(|(_, n)| n.clone()))
            .collect();
        if word == "mod" {
            let mut k = i + 3;
            while k < b.len() && b[k].is_whitespace() {
                k += 1;
            }
            pending_mod = Some(word_at(k));
            i = k;
            continue;
        }
        if word == "use" {
            // A use tree, up to its `;`.
            let start_line = line;
            let k = b[i..]
                .iter()
                .position(|&ch| ch == ';')
                .map_or(b.len(), |n| i + n);
            let tree: String = b[i + 3..k].iter().collect();
            line += tree.matches('\n').count();
            for path in expand(&tree) {
                let first = path.split("::").next().unwrap_or("");
                let relative = matches!(first, "crate" | "super" | "self")
                    || (children.contains(first) && inline.is_empty());
                if relative && let Some(target) = resolve(&here, &path) {
                    out.push(Import {
                        line: start_line,
                        written: path,
                        target,
                    });
                }
            }
            i = k;
            continue;
        }
        if matches!(word.as_str(), "crate" | "super" | "self")
            && b.get(i + word.len()) == Some(&':')
        {
            // An inline path: crate::a::b, super::super::c.
            let k = b[i..]
                .iter()
                .position(|&ch| !is_ident(ch) && ch != ':')
                .map_or(b.len(), |n| i + n);
            let written: String = b[i..k].iter().collect();
            let written = written.trim_end_matches(':').to_string();
            if let Some(target) = resolve(&here, &written) {
                out.push(Import {
                    line,
                    written,
                    target,
                });
            }
            i = k;
            continue;
        }
        i += word.len();
    }
    out
}

/// The paths of a use tree (`crate::{a, b::{c, d as e}}` → `crate::a`,
/// `crate::b::c`, `crate::b::d`): renames keep the original name, `self` in
/// a group names the group's module.
fn expand(tree: &str) -> Vec<String> {
    let words: Vec<&str> = tree.split_whitespace().collect();
    let mut flat = String::new();
    let mut k = 0;
    while k < words.len() {
        if words[k] == "as" && k + 1 < words.len() {
            // Drop ` as name`, keep what follows the name (`,`, `}`).
            flat.push_str(
                words[k + 1].trim_start_matches(|c: char| c.is_alphanumeric() || c == '_'),
            );
            k += 2;
        } else {
            flat.push_str(words[k]);
            k += 1;
        }
    }
    let mut out = Vec::new();
    expand_into("", &flat, &mut out);
    out
}

fn expand_into(prefix: &str, tree: &str, out: &mut Vec<String>) {
    let join = |p: &str, s: &str| {
        if p.is_empty() {
            s.to_string()
        } else if s == "self" {
            p.to_string()
        } else {
            format!("{p}::{s}")
        }
    };
    // Split at top-level commas.
    let mut parts = Vec::new();
    let (mut level, mut from) = (0, 0);
    for (k, ch) in tree.char_indices() {
        match ch {
            '{' => level += 1,
            '}' => level -= 1,
            ',' if level == 0 => {
                parts.push(&tree[from..k]);
                from = k + 1;
            }
            _ => {}
        }
    }
    parts.push(&tree[from..]);
    for part in parts.into_iter().filter(|p| !p.is_empty()) {
        match part.find('{') {
            Some(open) => {
                let head = part[..open].trim_end_matches("::");
                let inner = &part[open + 1..part.rfind('}').unwrap_or(part.len())];
                expand_into(&join(prefix, head), inner, out);
            }
            None => out.push(join(prefix, part.trim_end_matches("::"))),
        }
    }
}

/// The module path (`"io/grdecl/Lexer"`) that `path` (`crate::…`,
/// `super::…`, `self::…` or a child's `x::…`) names from module `here`;
/// `None` when it leaves the crate root.
fn resolve(here: &[String], path: &str) -> Option<String> {
    let mut segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
    let mut at: Vec<String> = here.to_vec();
    match segs.first().copied() {
        Some("crate") => {
            at.clear();
            segs.remove(0);
        }
        Some("self") => {
            segs.remove(0);
        }
        _ => {}
    }
    while segs.first() == Some(&"super") {
        at.pop()?;
        segs.remove(0);
    }
    at.extend(segs.iter().map(|s| s.to_string()));
    Some(at.join("/"))
}

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file under `src/` (`io/grdecl/mod.rs` →
/// `["io", "grdecl"]`; `lib.rs`, `main.rs` → their own names as keys).
fn module_of(rel: &Path) -> Vec<String> {
    let mut segs: Vec<String> = rel
        .with_extension("")
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    if segs.last().is_some_and(|s| s == "mod") {
        segs.pop();
    }
    segs
}

/// The violations in the sources under `src`: files in no layer, imports
/// from a layer above the file's (but the [`PENDING`] ones), and
/// [`PENDING`] rows that no longer occur.
fn violations(src: &Path) -> Vec<String> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    assert!(
        files.len() > 50,
        "only {} files under {}",
        files.len(),
        src.display()
    );
    let mut bad = Vec::new();
    let mut pending_seen = BTreeSet::new();
    for file in &files {
        let rel = file.strip_prefix(src).unwrap();
        let module = module_of(rel);
        let key = module.join("/");
        let Some(layer) = layer_of(&key) else {
            bad.push(format!(
                "src/{}: in no layer: add `{key}` to a row of LAYERS in src/layers.rs",
                rel.display()
            ));
            continue;
        };
        // lib.rs and main.rs are their crate's root: their paths start there.
        let root = matches!(key.as_str(), "lib" | "main");
        let here = if root { Vec::new() } else { module };
        let text = std::fs::read_to_string(file).unwrap();
        for imp in imports(&here, &text) {
            let Some(to) = layer_of(&imp.target) else {
                continue;
            };
            if to <= layer {
                continue;
            }
            if let Some(p) = PENDING
                .iter()
                .position(|&(m, t)| m == key && imp.target == t)
            {
                pending_seen.insert(p);
                continue;
            }
            bad.push(format!(
                "src/{}:{}: `{}`: {} ({}) imports {} from a layer above it ({})",
                rel.display(),
                imp.line,
                imp.written,
                key,
                LAYERS[layer].0,
                imp.target,
                LAYERS[to].0,
            ));
        }
    }
    for (p, (m, t)) in PENDING.iter().enumerate() {
        if !pending_seen.contains(&p) {
            bad.push(format!(
                "PENDING row ({m:?}, {t:?}) no longer occurs: remove it from src/layers.rs"
            ));
        }
    }
    bad
}

#[test]
fn no_module_imports_from_a_layer_above_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let bad = violations(&src);
    assert!(
        bad.is_empty(),
        "{} layering violation(s) (layers, bottom to top: {}):\n{}",
        bad.len(),
        LAYERS
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(" ← "),
        bad.join("\n")
    );
}

#[test]
fn imports_are_found_and_resolved() {
    let here: Vec<String> = ["io", "grdecl"].iter().map(|s| s.to_string()).collect();
    let src = r#"
//! Doc: crate::gpu::render is only mentioned here.
use super::{number::parse as p, vtk_read::{self, common::*}};
use crate::grid::Grid;
use lexer::Lexer;
use std::io::Read;
mod lexer;
/* crate::sweep::x in a block comment */
fn f() -> char {
    let s = "crate::pipeline::run";
    let _ = crate::structures::cpgraph::build(1);
    '{'
}
#[cfg(test)]
mod tests {
    use super::*;
    fn g<'a>(x: &'a str) -> &'a str { super::super::mesh::f(x) }
}
"#;
    let got: Vec<(usize, String)> = imports(&here, src)
        .into_iter()
        .map(|i| (i.line, i.target))
        .collect();
    let want: Vec<(usize, String)> = [
        (3, "io/number/parse"),
        (3, "io/vtk_read"),
        (3, "io/vtk_read/common/*"),
        (4, "grid/Grid"),
        (5, "io/grdecl/lexer/Lexer"),
        (11, "structures/cpgraph/build"),
        (16, "io/grdecl/*"),
        (17, "io/mesh/f"),
    ]
    .iter()
    .map(|&(l, t)| (l, t.to_string()))
    .collect();
    assert_eq!(got, want);
    assert_eq!(layer_of("gpu/view/scene"), Some(6));
    assert_eq!(layer_of("policy/render"), Some(7));
    assert_eq!(layer_of("py/grid"), Some(8));
    assert_eq!(layer_of("gpu/context"), Some(4));
    assert_eq!(layer_of("gpu/render/camera"), Some(5));
    assert_eq!(layer_of("io/grdecl/lexer"), Some(0));
    assert_eq!(layer_of("nowhere"), None);
}
