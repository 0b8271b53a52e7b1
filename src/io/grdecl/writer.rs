//! The GRDECL writer.

use super::*;

// ---------------------------------------------------------------------------
// Writer

/// Writes a corner-point grid as GRDECL (SPECGRID, optional MAPAXES,
/// COORD, ZCORN, ACTNUM, then every property), with `N*v` runs.
pub fn write_grdecl(w: &mut impl Write, g: &CornerPointGrid) -> io::Result<()> {
    let [nx, ny, nz] = g.dims;
    if let Some(u) = &g.mapunits {
        writeln!(w, "MAPUNITS\n  '{u}' /\n")?;
    }
    if let Some(m) = &g.mapaxes {
        writeln!(
            w,
            "MAPAXES\n  {} {} {} {} {} {} /\n",
            m[0], m[1], m[2], m[3], m[4], m[5]
        )?;
    }
    if let Some(u) = &g.gridunit {
        writeln!(w, "GRIDUNIT\n  '{u}' '' /\n")?;
    }
    writeln!(w, "SPECGRID\n  {nx} {ny} {nz} 1 F /\n")?;
    write_array(w, "COORD", &g.coord, 6)?;
    write_array(w, "ZCORN", &g.zcorn, 6)?;
    if let Some(a) = &g.actnum {
        let v: Vec<f64> = a.iter().map(|&x| x as f64).collect();
        write_array(w, "ACTNUM", &v, 6)?;
    }
    for p in &g.properties {
        write_array(w, &p.name, &p.values, 6)?;
    }
    Ok(())
}

/// Writes one keyword, six values (or runs) per line, runs as `N*v`.
fn write_array(w: &mut impl Write, kw: &str, v: &[f64], per_line: usize) -> io::Result<()> {
    writeln!(w, "{kw}")?;
    let mut i = 0;
    let mut on_line = 0;
    let mut s = String::with_capacity(64);
    while i < v.len() {
        let mut j = i + 1;
        while j < v.len() && v[j].to_bits() == v[i].to_bits() {
            j += 1;
        }
        s.clear();
        if j - i > 1 {
            use std::fmt::Write as _;
            let _ = write!(s, "{}*{}", j - i, v[i]);
        } else {
            use std::fmt::Write as _;
            let _ = write!(s, "{}", v[i]);
        }
        w.write_all(s.as_bytes())?;
        on_line += 1;
        if on_line == per_line {
            w.write_all(b"\n")?;
            on_line = 0;
        } else {
            w.write_all(b" ")?;
        }
        i = j;
    }
    w.write_all(b"/\n\n")
}
