//! EGRID / INIT: round trip through the array writer, INIT properties of
//! active cells, errors, and a fuzzed record reader.

use std::path::Path;

use proptest::prelude::*;
use stratasweep::io::egrid::{
    ArrayReader, EclData, add_init_properties, parse_egrid, read_egrid, write_array,
};

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
    let d = std::env::temp_dir().join(format!("stratasweep-egrid-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
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
