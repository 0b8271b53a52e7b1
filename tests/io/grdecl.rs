//! GRDECL tokenizer and reader: syntax, every bad-input error (naming file,
//! line and keyword), includes, fuzzing, and the writer round trip.

use std::path::Path;

use proptest::prelude::*;
use stratasweep::cornerpoint::CornerPointGrid;
use stratasweep::io::grdecl::{
    GrdeclDeck, GrdeclError, parse_number, read_grdecl, read_grdecl_from, write_grdecl,
};

use crate::support;

fn parse(text: &str) -> Result<GrdeclDeck, GrdeclError> {
    read_grdecl_from(text.as_bytes(), Path::new("mem.grdecl"))
}

/// A 2×1×1 grid with vertical pillars (x = 0, 1, 2; y = 0, 1) and depths 1000..1010.
fn small(extra: &str) -> String {
    format!(
        "SPECGRID\n 2 1 1 1 F /\nCOORD\n\
         0 0 1000 0 0 1010  1 0 1000 1 0 1010  2 0 1000 2 0 1010\n\
         0 1 1000 0 1 1010  1 1 1000 1 1 1010  2 1 1000 2 1 1010 /\n\
         ZCORN\n 8*1000 8*1010 /\n{extra}"
    )
}

#[test]
fn numbers() {
    let cases: [(&str, f64); 12] = [
        ("1", 1.0),
        ("-2.5", -2.5),
        (".5", 0.5),
        ("3.", 3.0),
        ("1e-3", 1e-3),
        ("1.0D+03", 1000.0),
        ("+7", 7.0),
        ("0.000123", 0.000123),
        ("1771.831", 1771.831),
        ("12345678901234567890123", 12345678901234567890123.0),
        ("0.1234567890123456789012", 0.123_456_789_012_345_68),
        ("5.0E-310", 5.0e-310),
    ];
    for (s, v) in cases {
        assert_eq!(parse_number(s.as_bytes()), Some(v), "{s}");
    }
    for s in ["", "-", "e5", "1e", "1.2.3", "abc", "1*2", "--"] {
        assert_eq!(parse_number(s.as_bytes()), None, "{s}");
    }
    assert!(parse_number(b"nan").unwrap().is_nan());
}

proptest! {
    #[test]
    fn numbers_match_std(x in proptest::num::f64::NORMAL | proptest::num::f64::SUBNORMAL, digits in 0usize..18) {
        for s in [format!("{x}"), format!("{x:e}"), format!("{x:.digits$}"), format!("{x:.digits$e}")] {
            prop_assert_eq!(parse_number(s.as_bytes()), s.parse::<f64>().ok(), "{}", s);
        }
    }
}

#[test]
fn syntax_comments_repeats_defaults_quotes() {
    let t = "-- a comment line\n\
             MAPUNITS -- trailing comment\n 'METRES ' /\n\
             GRIDUNIT\n\"METRES\" ' ' /\n\
             MAPAXES\n 0 100 0 0 100 0 /\n\
             DIMENS\n 2 1 1 /\n\
             SPECGRID\n 2 1 1 1* F /\n\
             COORD\n 0 0 1000 0 0 1010 1 0 1000 1 0 1010 2 0 1000 2 0 1010\n\
             0 1 1000 0 1 1010 1 1 1000 1 1 1010 2 1 1000 2 1 1010/\n\
             ZCORN\n 4*1000 2*1000.0 1000 1.0E3 -- comment in data\n 8*1010 /\n\
             ACTNUM\n 1* 0 /\n\
             PORO\n 0.25 0.5/\n\
             NTG\n 2*1 /\n\
             FOO\n 1 2 3 /\n\
             BAR\n 0.1 0.2 /\n";
    let d = parse(t).unwrap();
    let g = &d.grid;
    assert_eq!(g.dims, [2, 1, 1]);
    assert_eq!(g.zcorn[..8], [1000.0; 8]);
    assert_eq!(g.zcorn[8..], [1010.0; 8]);
    assert_eq!(g.actnum.as_deref(), Some(&[1u8, 0][..]));
    assert_eq!(g.mapunits.as_deref(), Some("METRES"));
    assert_eq!(g.gridunit.as_deref(), Some("METRES"));
    assert_eq!(g.mapaxes, Some([0.0, 100.0, 0.0, 0.0, 100.0, 0.0]));
    let names: Vec<&str> = g.properties.iter().map(|p| p.name.as_str()).collect();
    // BAR has one record of nx·ny·nz numbers: a property; FOO does not fit.
    assert_eq!(names, ["PORO", "NTG", "BAR"]);
    assert_eq!(g.properties[0].values, [0.25, 0.5]);
    assert_eq!(d.skipped, ["FOO"]);
}

#[test]
fn deck_reads_only_the_grid_section_and_reports_skips_once() {
    let t = format!(
        "RUNSPEC\nTITLE\n  My model 1 2 3\nDIMENS\n 2 1 1 /\nOIL\nWATER\nSTART\n 1 'JAN' 2000 /\n\
         TABDIMS\n 1 1 /\nTABDIMS\n 2 2 /\nGRID\nNOECHO\n{}\
         GDORIENT\nINC INC INC DOWN RIGHT /\n\
         PORO\n 0.1 0.2 /\nMULTIPLY\nPORO 2 /\n/\nPROPS\nPERMX\n 1 2 3 /\nMULTIPLY\nPORO 2 /\n/\n",
        small("")
    );
    let d = parse(&t).unwrap();
    assert_eq!(d.grid.properties.len(), 1, "{:?}", d.grid.properties);
    // MULTIPLY in the GRID section applies; the PROPS section is not read.
    assert_eq!(d.grid.properties[0].values, [0.2, 0.4]);
    assert_eq!(d.skipped, ["START", "TABDIMS", "GDORIENT"]);
}

#[test]
fn window_boundaries_do_not_split_tokens() {
    // Comments and values across window edges (1 MiB of text: many
    // windows).
    let mut t = String::from("SPECGRID\n 1 1 1 /\n");
    while t.len() < (1 << 20) - 7 {
        t.push_str("-- padding padding padding padding padding\n");
    }
    t.push_str(
        "COORD\n 0 0 0 0 0 1 1 0 0 1 0 1 0 1 0 0 1 1 1 1 0 1 1 1 /\nZCORN\n 4*0 4*1.000000001 /\n",
    );
    let d = parse(&t).unwrap();
    assert_eq!(d.grid.zcorn[7], 1.000000001);
    let long = format!("{}\n{}", "-".repeat(3 << 20), t);
    assert!(parse(&long).is_ok());
}

#[test]
fn values_across_many_window_edges_read_exactly() {
    // 120 000 values of 3 to 18 characters (~600 kB: several read windows,
    // so many values and repeats straddle a refill) read back exactly.
    let n = 120_000;
    let mut body = String::new();
    let mut want = Vec::with_capacity(n);
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    while want.len() < n {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let digits = (x % 13) as usize;
        let v = format!(
            "{}.{:0width$}",
            x % 100_000,
            (x >> 20) % 10u64.pow(digits as u32),
            width = digits
        );
        let r = 1 + (x >> 40) as usize % 3;
        let r = r.min(n - want.len());
        if r > 1 {
            body.push_str(&format!("{r}*"));
        }
        body.push_str(&v);
        body.push(if x & 16 == 0 { ' ' } else { '\n' });
        want.extend(std::iter::repeat_n(v.parse::<f64>().unwrap(), r));
    }
    let text = format!(
        "SPECGRID\n 1 1 {n} 1 F /\nCOORD\n 0 0 0 0 0 1 1 0 0 1 0 1 0 1 0 0 1 1 1 1 0 1 1 1 /\n\
         ZCORN\n {}*1 /\nPORO\n{body}/\n",
        8 * n
    );
    assert!(text.len() > 400_000);
    let d = parse(&text).unwrap();
    assert_eq!(d.grid.properties[0].values, want);
}

fn err(text: &str) -> String {
    let e = parse(text).unwrap_err();
    e.to_string()
}

#[test]
fn bad_inputs_name_file_line_keyword_and_counts() {
    // Missing SPECGRID.
    let e = err("COORD\n 1 2 3 /\n");
    assert!(
        e.contains("mem.grdecl:1:") && e.contains("COORD") && e.contains("SPECGRID"),
        "{e}"
    );
    let e = err("PORO\n 1 /\n");
    assert!(e.contains("PORO") && e.contains("SPECGRID"), "{e}");
    let e = err("-- nothing\n");
    assert!(e.contains("SPECGRID"), "{e}");
    // Wrong COORD count.
    let e = err("SPECGRID\n 2 1 1 /\nCOORD\n 1 2 3 /\n");
    assert!(
        e.contains(":3:") && e.contains("COORD") && e.contains("3 values, expected 36"),
        "{e}"
    );
    // Truncated ZCORN (end of file) and ZCORN running into the next keyword.
    let e = err(&small("").replace("8*1010 /", "8*1010"));
    assert!(
        e.contains("ZCORN")
            && e.contains("truncated")
            && e.contains("16 values, expected 16")
            && e.contains("end of file"),
        "{e}"
    );
    let e = err(&small("").replace("8*1010 /", "7*1010\nACTNUM\n 2*1 /"));
    assert!(
        e.contains(":8:")
            && e.contains("ZCORN")
            && e.contains("15 values, expected 16")
            && e.contains("keyword ACTNUM"),
        "{e}"
    );
    let e = err(&small("").replace("8*1010 /", "9*1010 /"));
    assert!(
        e.contains(":6:") && e.contains("ZCORN has 17 values, expected 16"),
        "{e}"
    );
    // Bad repeats.
    for (tok, why) in [
        ("*5", "missing"),
        ("0*1", "zero"),
        ("2.5*3", "not a positive integer"),
        ("3*", "no default"),
    ] {
        let e = err(&small("").replace("8*1010 /", &format!("5*1010 {tok} /")));
        assert!(
            e.contains(":7:") && e.contains("ZCORN") && e.contains(tok) && e.contains(why),
            "{tok}: {e}"
        );
    }
    // Non-numeric, NaN, infinity.
    let e = err(&small("").replace("8*1010 /", "7*1010 abc /"));
    assert!(
        e.contains(":7:") && e.contains("ZCORN") && e.contains("'abc' is not a number"),
        "{e}"
    );
    let e = err(&small("").replace("8*1010 /", "7*1010 'x' /"));
    assert!(e.contains("ZCORN") && e.contains("not a number"), "{e}");
    let e = err(&small("").replace("8*1010 /", "7*1010 NaN /"));
    assert!(
        e.contains(":7:") && e.contains("ZCORN") && e.contains("NaN") && e.contains("not finite"),
        "{e}"
    );
    let e = err(&small("").replace("8*1010 /", "7*1010 2*inf /"));
    assert!(e.contains("not finite"), "{e}");
    // Wrong property length.
    let e = err(&small("PORO\n 0.1 0.2 0.3 /\n"));
    assert!(
        e.contains(":8:") && e.contains("PORO has 3 values, expected 2"),
        "{e}"
    );
    // ACTNUM not 0/1.
    let e = err(&small("ACTNUM\n 1 2 /\n"));
    assert!(
        e.contains(":8:") && e.contains("ACTNUM") && e.contains("value 2 at cell 1"),
        "{e}"
    );
    // Bad SPECGRID.
    let e = err("SPECGRID\n 2 0 1 /\n");
    assert!(e.contains("SPECGRID") && e.contains(":1:"), "{e}");
    let e = err("SPECGRID\n 2 1 /\n");
    assert!(e.contains("SPECGRID has 2 values, expected 3"), "{e}");
    let e = err("SPECGRID\n 2 1 1 1 T /\n");
    assert!(e.contains("radial"), "{e}");
    // Unterminated string.
    let e = err("MAPUNITS\n 'METRES /\n");
    assert!(e.contains(":2:") && e.contains("unterminated"), "{e}");
    // Missing ZCORN.
    let e = err("SPECGRID\n 1 1 1 /\nCOORD\n 24*0 /\n");
    assert!(e.contains("ZCORN") && e.contains("missing"), "{e}");
}

#[test]
fn includes_relative_quoted_missing_and_cycles() {
    let dir = support::Dir::new("grdecl-inc");
    let d = &dir.0;
    std::fs::create_dir_all(d.join("sub")).unwrap();
    std::fs::write(
        d.join("sub/geom.inc"),
        small("INCLUDE\n 'props/poro.inc' /\n"),
    )
    .unwrap();
    std::fs::create_dir_all(d.join("sub/props")).unwrap();
    std::fs::write(d.join("sub/props/poro.inc"), "PORO\n 0.1 0.2 /\n").unwrap();
    // Unquoted names are allowed when they hold no '/' (which ends a record).
    std::fs::write(d.join("poro2.inc"), "PORO\n 0.1 0.2 /\n").unwrap();
    std::fs::write(
        d.join("main.grdecl"),
        "INCLUDE\n 'sub/geom.inc' /\nINCLUDE\n poro2.inc /\n",
    )
    .unwrap();
    let g = read_grdecl(d.join("main.grdecl")).unwrap();
    assert_eq!(g.grid.properties[0].values, [0.1, 0.2]);
    assert_eq!(g.files.len(), 4);
    // Fallback: an include path whose directories do not exist, found by file name.
    std::fs::write(
        d.join("sub/deck.DATA"),
        "INCLUDE\n '../include/grid/geom.inc' /\n",
    )
    .unwrap();
    assert!(read_grdecl(d.join("sub/deck.DATA")).is_ok());
    // Missing include.
    std::fs::write(
        d.join("missing.grdecl"),
        "-- x\n\nINCLUDE\n 'nowhere.inc' /\n",
    )
    .unwrap();
    let e = read_grdecl(d.join("missing.grdecl"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing.grdecl:3:") && e.contains("INCLUDE") && e.contains("nowhere.inc"),
        "{e}"
    );
    // Cycle a -> b -> a.
    std::fs::write(d.join("a.inc"), "INCLUDE\n 'b.inc' /\n").unwrap();
    std::fs::write(d.join("b.inc"), "\nINCLUDE\n 'a.inc' /\n").unwrap();
    let e = read_grdecl(d.join("a.inc")).unwrap_err().to_string();
    assert!(
        e.contains("b.inc:2:") && e.contains("INCLUDE") && e.contains("cycle"),
        "{e}"
    );
    // Self include.
    std::fs::write(d.join("self.inc"), "INCLUDE\n self.inc /\n").unwrap();
    assert!(
        read_grdecl(d.join("self.inc"))
            .unwrap_err()
            .to_string()
            .contains("cycle")
    );
    // Errors inside an include name the included file and its line.
    std::fs::write(d.join("bad.inc"), "\n\nPORO\n 1 2 3 /\n").unwrap();
    std::fs::write(d.join("top.grdecl"), small("INCLUDE\n bad.inc /\n")).unwrap();
    let e = read_grdecl(d.join("top.grdecl")).unwrap_err().to_string();
    assert!(e.contains("bad.inc:3:") && e.contains("PORO"), "{e}");
    let e = read_grdecl(d.join("no-such-file.grdecl"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no-such-file.grdecl"), "{e}");
    let _ = std::fs::remove_dir_all(d);
}

#[test]
fn writer_round_trips() {
    let g = CornerPointGrid {
        dims: [2, 1, 1],
        coord: vec![
            0.0, 0.0, 1000.0, 0.1, 0.0, 1010.0, 1.0, 0.0, 1000.0, 1.0, 0.0, 1010.0, 2.0, 0.0,
            1000.0, 2.0, 0.0, 1010.0, 0.0, 1.0, 1000.0, 0.0, 1.0, 1010.0, 1.0, 1.0, 1000.0, 1.0,
            1.0, 1010.0, 2.0, 1.0, 1000.0, 2.0, 1.0, 1010.0,
        ],
        zcorn: (0..16)
            .map(|i| 1000.0 + (i / 8) as f64 * 10.0 + 0.001 * (i % 3) as f64)
            .collect(),
        actnum: Some(vec![1, 0]),
        mapaxes: Some([1.5, 10.25, 1.5, 0.0, 11.0, 0.0]),
        mapunits: Some("METRES".into()),
        gridunit: Some("METRES".into()),
        properties: vec![stratasweep::grid::Property::scalar(
            "PORO",
            vec![0.1, 1.0 / 3.0],
        )],
    };
    let mut buf = Vec::new();
    write_grdecl(&mut buf, &g).unwrap();
    let back = read_grdecl_from(&buf[..], Path::new("w.grdecl"))
        .unwrap()
        .grid;
    assert_eq!(back, g);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    /// Random bytes and random mutations of a valid file never panic.
    #[test]
    fn fuzz_random_text_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = read_grdecl_from(&bytes[..], Path::new("fuzz.grdecl"));
    }

    #[test]
    fn fuzz_mutated_grid_never_panics(pos in 0usize..400, len in 0usize..8, ins in proptest::collection::vec(
        prop_oneof![Just(b'*'), Just(b'/'), Just(b'\''), Just(b'-'), Just(b' '), Just(b'\n'), Just(b'0'), Just(b'9'), Just(b'.'), Just(b'e'), Just(b'A')], 0..6)) {
        let mut t = small("ACTNUM\n 2*1 /\nPORO\n 0.1 0.2 /\nMAPAXES\n 0 1 0 0 1 0 /\n").into_bytes();
        let p = pos.min(t.len());
        let e = (p + len).min(t.len());
        t.splice(p..e, ins);
        if let Ok(d) = read_grdecl_from(&t[..], Path::new("fuzz.grdecl")) {
            // Whatever parses must convert (or fail) without panicking.
            let _ = d.grid.to_grid();
        }
    }

    /// Operator keywords with random records: an error or a result, never a panic.
    #[test]
    fn fuzz_operators_never_panic(records in proptest::collection::vec(proptest::collection::vec(
        prop_oneof![Just("PORO"), Just("'PERMX'"), Just("ACTNUM"), Just("MULTZ"), Just("ZCORN"),
            Just("1"), Just("0"), Just("2"), Just("3"), Just("-1"), Just("0.5"), Just("1*"), Just("3*"),
            Just("2*2"), Just("9*"), Just("1e400"), Just("x"), Just("/")], 0..10), 0..5),
        kw in prop_oneof![Just("EQUALS"), Just("MULTIPLY"), Just("ADD"), Just("COPY"), Just("BOX")]) {
        let mut extra = format!("{kw}\n");
        for r in &records {
            extra.push_str(&r.join(" "));
            extra.push_str(" /\n");
        }
        extra.push_str("/\n");
        let t = box_deck(&extra);
        if let Ok(d) = read_grdecl_from(t.as_bytes(), Path::new("fuzz.grdecl")) {
            let _ = d.grid.to_grid();
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random runs of plain numbers and `N*v` repeats (any separators,
    /// comments between them, `/` glued to the last value) read back as the
    /// expanded list, whatever the path (fast or general) takes them.
    #[test]
    fn repeats_and_numbers_expand_exactly(
        runs in proptest::collection::vec((1usize..6, -5000i64..5000, 0u8..4, 0u8..6), 1..60),
        glued in any::<bool>(),
    ) {
        let mut body = String::new();
        let mut want = Vec::new();
        for &(n, v, form, sep) in &runs {
            let x = v as f64 / 8.0;
            match (n, form) {
                (1, 0) => body.push_str(&format!("{x}")),
                (_, 1) => body.push_str(&format!("{n}*{x:e}")),
                _ => body.push_str(&format!("{n}*{x}")),
            }
            want.extend(std::iter::repeat_n(x, n));
            body.push_str(match sep {
                0 => " ",
                1 => "\n",
                2 => "\t ",
                3 => " -- note 3*7\n",
                4 => "\r\n",
                _ => "   ",
            });
        }
        if glued && runs.last().is_some_and(|r| r.3 != 3) {
            body = body.trim_end().to_string();
        }
        let n = want.len();
        let text = format!(
            "SPECGRID\n 1 1 {n} 1 F /\nCOORD\n 0 0 0 0 0 1 1 0 0 1 0 1 0 1 0 0 1 1 1 1 0 1 1 1 /\n\
             ZCORN\n {}*1 /\nPORO\n{body}/\n",
            8 * n
        );
        let d = parse(&text).unwrap();
        prop_assert_eq!(&d.grid.properties[0].values, &want);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Random decimal tokens (0–10 digits before the point, 0–18 after,
    /// signs, leading zeros, exponents, `N*v`, values glued to `/`), read
    /// through the streaming window, equal `str::parse::<f64>` bit for bit:
    /// the fast path gives the correctly rounded value or hands over to the
    /// standard library.
    #[test]
    fn decimal_tokens_parse_bit_identical_to_std(
        toks in proptest::collection::vec((0u8..3, "[0-9]{0,10}", any::<bool>(), "[0-9]{0,18}",
            prop_oneof![Just(String::new()), Just(String::new()), "[eEdD][+-]?[0-9]{1,2}"], 1usize..4, 0u8..3), 1..80),
    ) {
        let mut body = String::new();
        let mut want: Vec<f64> = Vec::new();
        for (sign, int, point, frac, exp, rep, sep) in &toks {
            let (int, frac) = if int.is_empty() && frac.is_empty() { ("0", frac.as_str()) } else { (int.as_str(), frac.as_str()) };
            let mut t = String::from(["", "-", "+"][*sign as usize]);
            t.push_str(int);
            if *point || int.is_empty() {
                t.push('.');
                t.push_str(frac);
            }
            t.push_str(exp);
            let v: f64 = t.replace(['d', 'D'], "e").parse().unwrap();
            if *rep > 1 {
                body.push_str(&format!("{rep}*"));
            }
            body.push_str(&t);
            body.push_str(["  ", "\n", " -- c\n"][*sep as usize]);
            want.extend(std::iter::repeat_n(v, *rep));
        }
        let n = want.len();
        let text = format!(
            "SPECGRID\n 1 1 {n} 1 F /\nCOORD\n 0 0 0 0 0 1 1 0 0 1 0 1 0 1 0 0 1 1 1 1 0 1 1 1 /\n\
             ZCORN\n {}*1 /\nPORO\n{}/\n",
            8 * n,
            // Glued to `/` unless a comment ends the list.
            body.trim_end_matches(' ')
        );
        let d = parse(&text).unwrap();
        let got = &d.grid.properties[0].values;
        prop_assert_eq!(got.len(), n);
        for (g, w) in got.iter().zip(&want) {
            prop_assert_eq!(g.to_bits(), w.to_bits(), "{} vs {}", g, w);
        }
    }
}

/// Inputs found by the fuzzers above (or written as their likely cousins), kept as regressions.
#[test]
fn fuzz_regressions() {
    for t in [
        "SPECGRID\n 99999999999999999999 1 1 /\n",
        "SPECGRID\n 100000 100000 100000 /\n",
        "SPECGRID\n 1 1 1 /\nZCORN\n 999999999999999*1 /\n",
        "SPECGRID\n 1 1 1 /\nACTNUM\n 99999999999999999999*1 /\n",
        "SPECGRID\n 1 1 1 /\nFOO\n 99999999999*1 /\n",
        "'",
        "\"abc",
        "/ / /",
        "--",
        "TITLE",
        "INCLUDE\n",
        "INCLUDE\n /",
        "MAPAXES\n 1 2 /",
        "SPECGRID\n 1 1 1 /\nCOORD\n 24*0 /\nZCORN\n 8*0 /\nMAPAXES\n 0 0 0 0 0 0 /\n",
        "SPECGRID\n 1 1 1 /\nCOORD\n 24*0 /\nZCORN\n 8*0 /\n",
        "SPECGRID\n 1* 1 1 /\n",
        "SPECGRID\n 1 1 1 3*1 /\n",
        "SPECGRID\n 1 1 1 /\nDIMENS\n 2 1 1 /\n",
    ] {
        if let Ok(d) = parse(t) {
            let _ = d.grid.to_grid();
        }
    }
    // A degenerate grid converts to an error or an empty grid, never a panic.
    let d = parse("SPECGRID\n 1 1 1 /\nCOORD\n 24*0 /\nZCORN\n 8*0 /\n").unwrap();
    let (g, r) = d.grid.to_grid().unwrap();
    assert_eq!((g.cell_count(), r.zero_volume), (0, 1));
}

/// The values of cell array `name`.
fn prop(g: &CornerPointGrid, name: &str) -> Vec<f64> {
    g.properties
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("no {name}"))
        .values
        .clone()
}

/// A 3×2×2 grid of unit cells (vertical pillars) followed by `extra`.
fn box_deck(extra: &str) -> String {
    let mut coord = String::new();
    for j in 0..3 {
        for i in 0..4 {
            coord.push_str(&format!("{i} {j} 0 {i} {j} 10\n"));
        }
    }
    format!(
        "SPECGRID\n 3 2 2 1 F /\nCOORD\n{coord}/\nZCORN\n 24*0 24*1 24*1 24*2 /\n\
         PORO\n 0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8 0.9 1.0 1.1 1.2 /\n{extra}"
    )
}

#[test]
fn equals_multiply_add_copy_in_boxes() {
    let d = parse(&box_deck(
        "EQUALS\n 'PERMX' 100 / whole grid\n/\n\
         MULTIPLY\n PERMX 0.5 1 2 1 1 1 1 /\n PERMX 2 2* 2 2 / I 1-2 of row J = 2, same K\n/\n\
         ADD\n PORO 1 3 3 /\n/\n\
         COPY\n PORO PERMZ /\n/\n\
         EQUALS\n MULTZ 0.01 1 3 1 2 2 2 /\n/\n\
         BOX\n 2 2 1 2 1 2 /\nEQUALS\n NTG 0.5 /\n/\nENDBOX\n\
         EQUALS\n ACTNUM 0 3 3 2 2 2 2 /\n/\n",
    ))
    .unwrap();
    let prop = |n: &str| prop(&d.grid, n);
    let g = &d.grid;
    let idx = |i: usize, j: usize, k: usize| i + 3 * (j + 2 * k);
    let mut permx = vec![100.0; 12];
    for i in 0..2 {
        permx[idx(i, 0, 0)] *= 0.5;
        permx[idx(i, 1, 0)] *= 2.0;
    }
    assert_eq!(prop("PERMX"), permx);
    // PORO + 1 in column I = 3 (J, K defaulted to the whole grid), PERMZ a copy.
    let mut poro: Vec<f64> = (1..=12).map(|x| x as f64 / 10.0).collect();
    for j in 0..2 {
        for k in 0..2 {
            poro[idx(2, j, k)] += 1.0;
        }
    }
    assert_eq!(prop("PORO"), poro);
    assert_eq!(prop("PERMZ"), poro);
    let multz: Vec<f64> = (0..12).map(|c| if c >= 6 { 0.01 } else { 1.0 }).collect();
    assert_eq!(prop("MULTZ"), multz);
    let ntg: Vec<f64> = (0..12)
        .map(|c| if c % 3 == 1 { 0.5 } else { 1.0 })
        .collect();
    assert_eq!(prop("NTG"), ntg);
    let mut act = [1u8; 12];
    act[idx(2, 1, 1)] = 0;
    assert_eq!(g.actnum.as_deref(), Some(&act[..]));
}

#[test]
fn operator_errors_name_file_line_and_keyword() {
    let cases = [
        (
            "MULTIPLY\n PERMX 2 /\n/\n",
            "mem.grdecl:22: MULTIPLY: MULTIPLY on PERMX, which is not defined",
        ),
        (
            "EQUALS\n PERMY 7 2 3 1* 1* 2 2 /\n/\n",
            "EQUALS defines PERMY in part of the grid only",
        ),
        (
            "ADD\n PORO 1 1 4 /\n/\n",
            "box index 4 is out of range: I runs from 1 to 3",
        ),
        ("ADD\n PORO 1 2 1 /\n/\n", "box I 2..1 is not within 1..3"),
        ("MULTIPLY\n PORO x /\n/\n", "'x' is not a finite number"),
        (
            "MULTIPLY\n PORO 2 1 1 1 1 1 0.5 /\n/\n",
            "box index '0.5' is not a positive integer",
        ),
        (
            "COPY\n PERMX PORO /\n/\n",
            "COPY from PERMX, which is not defined",
        ),
        ("COPY\n PORO /\n/\n", "found 1 item(s)"),
        ("EQUALS\n ZCORN 1 /\n/\n", "EQUALS cannot change ZCORN"),
        (
            "MULTIPLY\n ACTNUM 2 /\n/\n",
            "MULTIPLY cannot change ACTNUM",
        ),
        (
            "EQUALS\n ACTNUM 2 /\n/\n",
            "EQUALS ACTNUM: value 2 at cell 0 is not 0 or 1",
        ),
        ("EQUALS\n PORO 1 /\n", "end of file before the closing '/'"),
        (
            "BOX\n 1 2 1 2 1 3 /\n",
            "box index 3 is out of range: K runs from 1 to 2",
        ),
    ];
    for (extra, want) in cases {
        let e = parse(&box_deck(extra)).unwrap_err().to_string();
        assert!(e.contains(want), "{extra:?}: got '{e}', want '{want}'");
        assert!(e.contains("mem.grdecl:"), "{e}");
    }
}

#[test]
fn spe9_and_reek_operators() {
    let Some(data) = support::data_dir("spe9_and_reek_operators") else {
        return;
    };
    // SPE9's deck: COPY PERMX to PERMY and PERMZ, then MULTIPLY PERMZ 0.01.
    let d = read_grdecl(data.join("spe9/SPE9_CP.DATA")).unwrap();
    let px = prop(&d.grid, "PERMX");
    assert_eq!(prop(&d.grid, "PERMY"), px);
    let pz: Vec<f64> = px.iter().map(|x| x * 0.01).collect();
    assert_eq!(prop(&d.grid, "PERMZ"), pz);
    assert!(!d.skipped.iter().any(|s| s == "COPY" || s == "MULTIPLY"));
    // Reek's MULTZ barrier: EQUALS 'MULTZ' 0.01 1 40 1 64 5 5 / (a comment
    // after the '/'): layer 5 only, 1 elsewhere.
    let dir = support::tmp_dir("grdecl-multz");
    let deck = dir.join("reek_multz.grdecl");
    std::fs::write(
        &deck,
        format!(
            "INCLUDE\n '{}' /\nINCLUDE\n '{}' /\n",
            data.join("reek/reek.grid").display(),
            data.join("reek/reek.multz").display()
        ),
    )
    .unwrap();
    let d = read_grdecl(&deck).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let m = prop(&d.grid, "MULTZ");
    assert_eq!(m.len(), 40 * 64 * 14);
    for (c, &v) in m.iter().enumerate() {
        assert_eq!(v, if c / (40 * 64) == 4 { 0.01 } else { 1.0 }, "cell {c}");
    }
}
