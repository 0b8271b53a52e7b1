//! Writes a corner-point grid as an EGRID file (main grid: GRIDHEAD,
//! MAPAXES, COORD, ZCORN, ACTNUM, ENDGRID; COORD and ZCORN as REAL, as
//! Eclipse writes them) and its cell properties as an INIT file.

use std::io::{self, Write};

use crate::cornerpoint::CornerPointGrid;
use crate::io::egrid::{EclData, write_array};

fn reals(v: &[f64]) -> EclData {
    EclData::Real(v.iter().map(|&x| x as f32).collect())
}

/// Writes `g`'s geometry in EGRID form (big-endian Fortran records).
pub fn write_egrid(out: &mut impl Write, g: &CornerPointGrid) -> io::Result<()> {
    let [nx, ny, nz] = g.dims.map(|d| d as i32);
    let mut filehead = vec![0; 100];
    filehead[0] = 3; // version
    filehead[1] = 2007; // release year
    write_array(out, "FILEHEAD", &EclData::Int(filehead))?;
    if let Some(u) = &g.mapunits {
        write_array(out, "MAPUNITS", &EclData::Char(vec![u.clone()]))?;
    }
    if let Some(m) = &g.mapaxes {
        write_array(out, "MAPAXES", &reals(m))?;
    }
    if let Some(u) = &g.gridunit {
        write_array(
            out,
            "GRIDUNIT",
            &EclData::Char(vec![u.clone(), String::new()]),
        )?;
    }
    let mut head = vec![0; 100];
    head[..4].copy_from_slice(&[1, nx, ny, nz]);
    write_array(out, "GRIDHEAD", &EclData::Int(head))?;
    write_array(out, "COORD", &reals(&g.coord))?;
    write_array(out, "ZCORN", &reals(&g.zcorn))?;
    let n = g.cell_count();
    let act: Vec<i32> = (0..n).map(|c| g.is_active(c) as i32).collect();
    write_array(out, "ACTNUM", &EclData::Int(act))?;
    write_array(out, "ENDGRID", &EclData::Message)
}

/// Writes `g`'s cell properties as INIT arrays (one value per cell, REAL).
/// Returns false (and writes nothing) when `g` has none.
pub fn write_init(out: &mut impl Write, g: &CornerPointGrid) -> io::Result<bool> {
    if g.properties.is_empty() {
        return Ok(false);
    }
    for p in &g.properties {
        let v: Vec<f64> = (0..p.len()).map(|i| p.scalar_at(i)).collect();
        write_array(out, &p.name, &reals(&v))?;
    }
    Ok(true)
}
