//! EGRID / INIT: round trip through the array writer, INIT properties of
//! active cells, errors, and a fuzzed record reader.

use std::path::Path;

use proptest::prelude::*;
use stratasweep::io::egrid::{
    ArrayReader, EclData, add_init_properties, parse_egrid, read_egrid, write_array,
};

use crate::support;

/// An EGRID of `generate::faulted` (f32 like a simulator writes), plus its grid.
fn egrid_bytes(g: &stratasweep::cornerpoint::CornerPointGrid) -> Vec<u8> {
    let [nx, ny, nz] = g.dims;
    let mut b = Vec::new();
    let f32s = |v: &[f64]| EclData::Real(v.iter().map(|&x| x as f32).collect());
    write_array(
        &mut b,
        "FILEHEAD",
        &EclData::Int(vec![3, 2007, 0, 0, 0, 0, 1]),
    )
    .unwrap();
    write_array(&mut b, "MAPUNITS", &EclData::Char(vec!["METRES".into()])).unwrap();
    write_array(&mut b, "MAPAXES", &f32s(&g.mapaxes.unwrap())).unwrap();
    write_array(
        &mut b,
        "GRIDHEAD",
        &EclData::Int(vec![1, nx as i32, ny as i32, nz as i32, 0, 0]),
    )
    .unwrap();
    write_array(&mut b, "COORD", &f32s(&g.coord)).unwrap();
    write_array(&mut b, "ZCORN", &f32s(&g.zcorn)).unwrap();
    let act: Vec<i32> = g
        .actnum
        .as_ref()
        .unwrap()
        .iter()
        .map(|&a| a as i32)
        .collect();
    write_array(&mut b, "ACTNUM", &EclData::Int(act)).unwrap();
    write_array(&mut b, "ENDGRID", &EclData::Int(vec![])).unwrap();
    // A local grid after ENDGRID must be ignored.
    write_array(&mut b, "LGR", &EclData::Char(vec!["LGR1".into()])).unwrap();
    write_array(&mut b, "GRIDHEAD", &EclData::Int(vec![1, 2, 2, 2])).unwrap();
    b
}

#[test]
fn egrid_round_trip_and_init_properties() {
    let g = stratasweep::generate::faulted([12, 9, 5], 2, 3);
    let bytes = egrid_bytes(&g);
    let e = parse_egrid(&bytes, Path::new("mem.EGRID")).unwrap();
    assert_eq!(e.dims, g.dims);
    assert_eq!(e.actnum, g.actnum);
    assert_eq!(e.mapunits.as_deref(), Some("METRES"));
    for (a, b) in g.zcorn.iter().zip(&e.zcorn) {
        assert_eq!(*a as f32, *b as f32);
    }
    // INIT: PORO for active cells only, PORV for all cells, headers ignored.
    let n = g.cell_count();
    let act: Vec<usize> = (0..n).filter(|&c| g.is_active(c)).collect();
    let poro = &g.properties[0].values;
    let mut init = Vec::new();
    write_array(&mut init, "INTEHEAD", &EclData::Int(vec![0; 95])).unwrap();
    write_array(&mut init, "LOGIHEAD", &EclData::Logical(vec![true; 15])).unwrap();
    write_array(&mut init, "PORV", &EclData::Real(vec![1.5; n])).unwrap();
    let ap: Vec<f32> = act.iter().map(|&c| poro[c] as f32).collect();
    write_array(&mut init, "PORO", &EclData::Real(ap)).unwrap();
    write_array(&mut init, "FIPNUM", &EclData::Int(vec![2; act.len()])).unwrap();
    let mut e2 = e.clone();
    let names = add_init_properties(&mut e2, &init, Path::new("mem.INIT")).unwrap();
    assert_eq!(names, ["PORV", "PORO", "FIPNUM"]);
    let p = &e2.properties[1].values;
    for c in 0..n {
        if g.is_active(c) {
            assert_eq!(p[c] as f32, poro[c] as f32);
        } else {
            assert_eq!(p[c], 0.0);
        }
    }
    // Files on disk: EGRID with its INIT beside it.
    let d = support::tmp_dir("egrid");
    std::fs::write(d.join("M.EGRID"), &bytes).unwrap();
    std::fs::write(d.join("M.INIT"), &init).unwrap();
    let f = read_egrid(d.join("M.EGRID")).unwrap();
    assert_eq!(f.init.as_deref(), Some(d.join("M.INIT").as_path()));
    assert_eq!(f.grid.properties.len(), 3);
    let (grid, rep) = f.grid.to_grid().unwrap();
    assert_eq!(grid.cell_data.len(), 3);
    assert_eq!(rep.active, act.len());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn egrid_errors() {
    let g = stratasweep::generate::faulted([4, 3, 2], 1, 1);
    let bytes = egrid_bytes(&g);
    let err = |b: &[u8]| {
        parse_egrid(b, Path::new("x.EGRID"))
            .unwrap_err()
            .to_string()
    };
    // Truncated in the middle of ZCORN.
    let e = err(&bytes[..bytes.len() / 2]);
    assert!(e.contains("x.EGRID") && e.contains("truncated"), "{e}");
    // Corrupt trailing marker of the first record.
    let mut b = bytes.clone();
    b[20] ^= 1;
    let e = err(&b);
    assert!(e.contains("markers"), "{e}");
    // Missing GRIDHEAD.
    let mut b = Vec::new();
    write_array(&mut b, "COORD", &EclData::Real(vec![0.0; 6])).unwrap();
    assert!(err(&b).contains("GRIDHEAD"));
    // Wrong ZCORN count.
    let mut b = Vec::new();
    write_array(&mut b, "GRIDHEAD", &EclData::Int(vec![1, 1, 1, 1])).unwrap();
    write_array(&mut b, "ZCORN", &EclData::Real(vec![0.0; 7])).unwrap();
    let e = err(&b);
    assert!(
        e.contains("ZCORN has 7 values") && e.contains("expected 8"),
        "{e}"
    );
    // Unknown type, bad header size.
    let mut b = Vec::new();
    write_array(&mut b, "GRIDHEAD", &EclData::Int(vec![1, 1, 1, 1])).unwrap();
    b[4 + 12..4 + 16].copy_from_slice(b"QQQQ");
    assert!(err(&b).contains("unknown type"));
    assert!(err(&[0, 0, 0, 3, 1, 2, 3, 0, 0, 0, 3]).contains("16"));
    // Absurd count: no huge allocation, an error.
    let mut b = Vec::new();
    write_array(&mut b, "ZCORN", &EclData::Real(vec![0.0; 2])).unwrap();
    b[4 + 8..4 + 12].copy_from_slice(&i32::MAX.to_be_bytes());
    assert!(err(&b).contains("truncated"));
    let e = read_egrid("/nonexistent/x.EGRID").unwrap_err().to_string();
    assert!(e.contains("/nonexistent/x.EGRID"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn fuzz_record_reader_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let mut r = ArrayReader::new(&bytes, Path::new("f.EGRID"));
        for _ in 0..100 {
            match r.next_array() {
                Ok(Some(_)) => {}
                _ => break,
            }
        }
        let _ = parse_egrid(&bytes, Path::new("f.EGRID"));
    }

    #[test]
    fn fuzz_mutated_egrid_never_panics(pos in 0usize..2000, vals in proptest::collection::vec(any::<u8>(), 1..6)) {
        let g = stratasweep::generate::faulted([3, 2, 2], 1, 2);
        let mut b = egrid_bytes(&g);
        let p = pos % b.len();
        for (k, v) in vals.iter().enumerate() {
            if p + k < b.len() {
                b[p + k] = *v;
            }
        }
        if let Ok(cp) = parse_egrid(&b, Path::new("f.EGRID")) {
            let _ = cp.to_grid();
        }
    }
}

/// Cases of the kind the fuzzers hit, kept as regressions.
#[test]
fn fuzz_regressions() {
    let cases: [&[u8]; 5] = [
        &[],
        &[0, 0, 0, 16],
        &[255, 255, 255, 255, 0, 0, 0, 0],
        &[0, 0, 0, 0, 0, 0, 0, 0],
        &[
            0, 0, 0, 16, b'G', b'R', b'I', b'D', b'H', b'E', b'A', b'D', 255, 255, 255, 255, b'I',
            b'N', b'T', b'E', 0, 0, 0, 16,
        ],
    ];
    for b in cases {
        let _ = parse_egrid(b, Path::new("r.EGRID"));
    }
    // GRIDHEAD with huge or negative dims is an error, not an allocation.
    let mut b = Vec::new();
    write_array(
        &mut b,
        "GRIDHEAD",
        &EclData::Int(vec![1, i32::MAX, i32::MAX, 2]),
    )
    .unwrap();
    assert!(parse_egrid(&b, Path::new("r.EGRID")).is_err());
    let mut b = Vec::new();
    write_array(&mut b, "GRIDHEAD", &EclData::Int(vec![1, -1, 2, 2])).unwrap();
    assert!(parse_egrid(&b, Path::new("r.EGRID")).is_err());
}

/// TEST_DP is a 5×3×1 dual-porosity model (FILEHEAD[5] = 1, ACTNUM 0–3,
/// INIT arrays of matrix then fracture values: PORV 2·15, PORO 11 + 13);
/// TEST_SP is the same model in single porosity, its matrix. Read as its
/// matrix, TEST_DP gives TEST_SP's cells and PORO/PORV exactly, with a
/// warning naming FILEHEAD[5] and the fracture cells skipped.
#[test]
fn dual_porosity_egrid_is_read_as_its_matrix_with_a_warning() {
    let Some(data) = support::data_dir("dual_porosity_egrid_is_read_as_its_matrix_with_a_warning")
    else {
        return;
    };
    let dp = stratasweep::io::load(&data.join("restart/TEST_DP.EGRID")).unwrap();
    let sp = stratasweep::io::load(&data.join("restart/TEST_SP.EGRID")).unwrap();
    let w = dp.warnings.join("\n");
    assert!(
        w.contains("FILEHEAD[5] = 1")
            && w.contains("dual porosity")
            && w.contains("only the matrix is shown")
            && w.contains("11 cells with an active matrix")
            && w.contains("fracture (13 active cells)"),
        "{w}"
    );
    assert!(
        !sp.warnings.iter().any(|w| w.contains("porosity")),
        "{:?}",
        sp.warnings
    );
    // ACTNUM 3 (both) or 1 (matrix) cells: 11 of the 15; the two
    // fracture-only cells (ACTNUM 2) are not shown.
    assert_eq!(dp.grid.cell_count(), 11);
    assert_eq!(dp.grid.points, sp.grid.points);
    assert_eq!(dp.grid.topology, sp.grid.topology);
    assert_eq!(
        dp.ijk.as_ref().unwrap().source_cell,
        sp.ijk.as_ref().unwrap().source_cell
    );
    for name in ["PORO", "PORV", "PERMX"] {
        let a = dp.grid.cell_property(name).unwrap();
        let b = sp.grid.cell_property(name).unwrap();
        assert_eq!(a.values, b.values, "{name}");
    }
    // PORO runs 0.10, 0.11, … by IJK index on the active cells.
    let poro = &dp.grid.cell_property("PORO").unwrap().values;
    for (o, &c) in dp.ijk.as_ref().unwrap().source_cell.iter().enumerate() {
        assert_eq!(poro[o] as f32, (0.1 + 0.01 * c as f64) as f32, "cell {c}");
    }
    // No INIT array was skipped as "wrong length": every per-cell array of
    // TEST_DP has its matrix half read.
    assert!(
        !w.contains("has 24 values") && !w.contains("has 30 values"),
        "{w}"
    );
}

/// EGRID arrays of a small local grid (`LGR` … `ENDLGR`), as Eclipse
/// writes one, for the grid `g` named `name`.
fn lgr_section(name: &str, g: &stratasweep::cornerpoint::CornerPointGrid) -> Vec<u8> {
    let mut b = Vec::new();
    let [nx, ny, nz] = g.dims.map(|d| d as i32);
    let reals = |v: &[f64]| EclData::Real(v.iter().map(|&x| x as f32).collect());
    write_array(&mut b, "LGR", &EclData::Char(vec![name.into()])).unwrap();
    write_array(&mut b, "LGRPARNT", &EclData::Char(vec!["".into()])).unwrap();
    write_array(&mut b, "GRIDHEAD", &EclData::Int(vec![1, nx, ny, nz, 0, 0])).unwrap();
    write_array(&mut b, "COORD", &reals(&g.coord)).unwrap();
    write_array(&mut b, "ZCORN", &reals(&g.zcorn)).unwrap();
    write_array(&mut b, "ACTNUM", &EclData::Int(vec![1; g.cell_count()])).unwrap();
    write_array(&mut b, "HOSTNUM", &EclData::Int(vec![1; g.cell_count()])).unwrap();
    write_array(&mut b, "ENDGRID", &EclData::Int(vec![])).unwrap();
    write_array(&mut b, "ENDLGR", &EclData::Int(vec![1])).unwrap();
    b
}

/// Local grid refinements, one before the main grid and one after it (with
/// an NNC section between): the main grid is the one outside the LGR
/// sections (same cells and volume as the EGRID without LGRs), and the load
/// warns naming both. An LGR section that never ends is an error naming it.
#[test]
fn local_grids_are_skipped_and_named_never_taken_as_the_main_grid() {
    let main = stratasweep::generate::faulted([6, 5, 3], 1, 4);
    let lgr = stratasweep::generate::faulted([2, 2, 2], 0, 9);
    let mut plain = Vec::new();
    stratasweep::io::egrid_write::write_egrid(&mut plain, &main).unwrap();
    let mut b = lgr_section("LGR1", &lgr);
    b.extend_from_slice(&plain);
    write_array(&mut b, "NNCHEAD", &EclData::Int(vec![1, 0, 0, 0])).unwrap();
    write_array(&mut b, "NNC1", &EclData::Int(vec![1])).unwrap();
    write_array(&mut b, "NNC2", &EclData::Int(vec![2])).unwrap();
    b.extend_from_slice(&lgr_section("LGR2", &lgr));
    let (cp, notes) = stratasweep::io::egrid::parse_egrid_notes(&b, Path::new("L.EGRID")).unwrap();
    assert_eq!(cp.dims, main.dims);
    assert_eq!(cp, parse_egrid(&plain, Path::new("P.EGRID")).unwrap());
    assert_eq!(notes.local_grids, ["LGR1", "LGR2"]);
    assert_eq!(notes.dual_porosity, None);
    let d = support::tmp_dir("egrid-lgr");
    std::fs::write(d.join("L.EGRID"), &b).unwrap();
    std::fs::write(d.join("P.EGRID"), &plain).unwrap();
    let l = stratasweep::io::load(&d.join("L.EGRID")).unwrap();
    let p = stratasweep::io::load(&d.join("P.EGRID")).unwrap();
    assert_eq!(l.grid, p.grid);
    assert_eq!(
        l.cornerpoint.as_ref().unwrap()["bulk_volume"],
        p.cornerpoint.as_ref().unwrap()["bulk_volume"]
    );
    let want = format!(
        "{}: 2 local grid refinements (LGR1, LGR2) skipped: only the main grid is shown",
        d.join("L.EGRID").display()
    );
    assert!(l.warnings.contains(&want), "{:?}", l.warnings);
    assert!(!p.warnings.iter().any(|w| w.contains("local grid")));
    // The warnings travel in the report `info --json` and Python print.
    let cpj = l.cornerpoint.as_ref().unwrap();
    assert!(
        cpj["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w == &want)
    );
    // An LGR first that never ends: no main grid, said so.
    let mut open = lgr_section("LONELY", &lgr);
    open.truncate(open.len() - 36); // drop ENDLGR (header 24 + data 12 bytes)
    let e = parse_egrid(&open, Path::new("O.EGRID")).map(|g| g.dims);
    assert!(
        matches!(&e, Err(err) if err.to_string().contains("LONELY")),
        "{e:?}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// An EGRID without its INIT: the load warns naming the INIT files looked
/// for, and `info` (a subprocess) prints it; with the INIT beside it, no
/// such warning.
#[test]
fn missing_init_is_named() {
    let g = stratasweep::generate::faulted([4, 3, 2], 1, 2);
    let d = support::tmp_dir("egrid-noinit");
    let egrid = d.join("M.EGRID");
    let mut b = Vec::new();
    stratasweep::io::egrid_write::write_egrid(&mut b, &g).unwrap();
    std::fs::write(&egrid, &b).unwrap();
    let l = stratasweep::io::load(&egrid).unwrap();
    let want = format!(
        "no INIT beside {} (looked for M.INIT, M.init): no properties",
        egrid.display()
    );
    assert_eq!(l.warnings, std::slice::from_ref(&want));
    assert!(l.grid.cell_data.is_empty());
    let out = support::bin().arg("info").arg(&egrid).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains(&format!("warning: {want}")), "{err}");
    // With its INIT: properties, no warning.
    let mut init = Vec::new();
    stratasweep::io::egrid_write::write_init(&mut init, &g).unwrap();
    std::fs::write(d.join("M.INIT"), &init).unwrap();
    let l = stratasweep::io::load(&egrid).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    assert!(l.grid.cell_property("PORO").is_some());
    let _ = std::fs::remove_dir_all(&d);
}
