//! The CLI's own writes, all atomic (`io::atomic`): statistics JSON and
//! `generate faulted` in the format its extension names.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use serde_json::Value;
use stratasweep::cornerpoint::CornerPointGrid;
use stratasweep::io::{self, atomic};

/// Extensions `generate faulted -o` writes.
pub const CORNERPOINT_EXTS: &[&str] = &["grdecl", "inc", "vtu", "egrid"];

/// The INIT file `generate faulted -o X.egrid` writes beside `X.egrid`
/// (upper case beside `.EGRID`).
pub fn init_beside(path: &Path) -> std::path::PathBuf {
    path.with_extension(if path.extension().is_some_and(|e| e == "EGRID") {
        "INIT"
    } else {
        "init"
    })
}

/// Writes `v` as pretty JSON into a temporary file beside `path`, flushed,
/// for the caller to commit once the outputs written with it are in place
/// (dropped uncommitted, it is removed and `path` stays as it was).
pub fn prepare_json(path: &Path, v: &Value) -> Result<atomic::AtomicFile> {
    let ctx = || format!("cannot write {}", path.display());
    let text = serde_json::to_string_pretty(v)?;
    let mut f = atomic::AtomicFile::create(path).with_context(ctx)?;
    f.write_all(text.as_bytes())
        .and_then(|_| f.flush())
        .with_context(ctx)?;
    Ok(f)
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
            let init = init_beside(path);
            // Both files are written in full before either replaces
            // anything: a failure leaves the old pair as it was.
            let mut egrid = atomic::AtomicFile::create(path).with_context(ctx)?;
            io::egrid_write::write_egrid(&mut egrid, &g)
                .and_then(|_| egrid.flush())
                .with_context(ctx)?;
            let init_ctx = || format!("cannot write {}", init.display());
            let init_file = if g.properties.is_empty() {
                None
            } else {
                let mut f = atomic::AtomicFile::create(&init).with_context(init_ctx)?;
                io::egrid_write::write_init(&mut f, &g)
                    .and_then(|_| f.flush())
                    .with_context(init_ctx)?;
                Some(f)
            };
            egrid.commit().with_context(ctx)?;
            let mut out = vec![path.display().to_string()];
            if let Some(f) = init_file {
                f.commit().with_context(init_ctx)?;
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
