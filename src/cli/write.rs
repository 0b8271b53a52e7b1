//! The CLI's own writes, all atomic (`io::atomic`): statistics JSON and
//! `generate faulted` in the format its extension names.

use std::path::Path;

use anyhow::{Context, Result};
use serde_json::Value;
use stratasweep::cornerpoint::CornerPointGrid;
use stratasweep::io::{self, atomic};

/// Extensions `generate faulted -o` writes.
pub const CORNERPOINT_EXTS: &[&str] = &["grdecl", "inc", "vtu", "egrid"];

/// Writes `v` as pretty JSON to `path` atomically.
pub fn write_json(path: &Path, v: &Value) -> Result<()> {
    let text = serde_json::to_string_pretty(v)?;
    atomic::write_bytes(path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Writes a corner-point grid as the extension `ext` says: GRDECL text
/// (`.grdecl`, `.inc`), a VTU zoo grid of its active cells (`.vtu`), or
/// EGRID (`.egrid`, with an INIT beside it holding the properties).
/// Returns the paths written.
pub fn write_cornerpoint(path: &Path, ext: &str, g: CornerPointGrid) -> Result<Vec<String>> {
    let ctx = || format!("cannot write {}", path.display());
    match ext {
        "vtu" => {
            let (grid, _) = g.into_grid().with_context(ctx)?;
            io::writers::write_vtk_xml_grid(path, &grid)?;
            Ok(vec![path.display().to_string()])
        }
        "egrid" => {
            let init = path.with_extension(if path.extension().is_some_and(|e| e == "EGRID") {
                "INIT"
            } else {
                "init"
            });
            atomic::write_with(path, |w| io::egrid_write::write_egrid(w, &g)).with_context(ctx)?;
            let mut out = vec![path.display().to_string()];
            if !g.properties.is_empty() {
                atomic::write_with(&init, |w| io::egrid_write::write_init(w, &g).map(|_| ()))
                    .with_context(|| format!("cannot write {}", init.display()))?;
                out.push(init.display().to_string());
            }
            Ok(out)
        }
        _ => {
            atomic::write_with(path, |w| io::grdecl::write_grdecl(w, &g)).with_context(ctx)?;
            Ok(vec![path.display().to_string()])
        }
    }
}
