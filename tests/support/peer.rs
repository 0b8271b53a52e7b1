//! Running VTK's plane cutter (`../shared/peer/vtk_slices.py`) on a grid
//! file, for tests that compare slice areas with VTK.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The peer's Python ([`super::peer_python`]) and script (beside the
/// checkout, `../shared/peer`, else beside the data,
/// `$STRATASWEEP_DATA/../peer`), or `None` after a loud SKIP line naming
/// `what` when no Python is given. Panics when a Python is given and the
/// script is missing.
pub fn peer(what: &str) -> Option<(PathBuf, PathBuf)> {
    let py = super::peer_python(what)?;
    let mut scripts =
        vec![Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/peer/vtk_slices.py")];
    if let Some(d) = std::env::var_os("STRATASWEEP_DATA") {
        scripts.push(Path::new(&d).join("../peer/vtk_slices.py"));
    }
    match scripts.iter().find(|s| s.exists()) {
        Some(s) => Some((py, s.clone())),
        None => panic!("{what}: the VTK peer's Python is given but no script: {scripts:?}"),
    }
}

/// VTK's slices of `grid` along `axis` (0–2) at `count` levels: the peer's
/// JSON (`slices: [{value, area, ..}]`), written to and removed from the
/// temp dir. Panics with VTK's stderr when the peer fails.
pub fn vtk_slices(
    py: &Path,
    script: &Path,
    grid: &Path,
    axis: usize,
    count: usize,
) -> serde_json::Value {
    let json = std::env::temp_dir().join(format!(
        "peer-{}-{}-{axis}-{count}.json",
        std::process::id(),
        grid.file_stem().unwrap().to_string_lossy()
    ));
    let out = Command::new(py)
        .arg(script)
        .arg(grid)
        .args([
            "--axis",
            ["x", "y", "z"][axis],
            "--count",
            &count.to_string(),
            "--json",
        ])
        .arg(&json)
        .output()
        .expect("run the peer");
    assert!(
        out.status.success(),
        "peer failed on {}: {}",
        grid.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let v = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&json);
    v
}
