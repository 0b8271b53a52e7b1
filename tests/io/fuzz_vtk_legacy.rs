//! Property tests: mutated legacy and XML VTK files must never make the
//! readers panic (or allocate from a bogus header count); `Ok` or `Err` are
//! both fine. Crashes found along the way are kept as named regression tests.

use proptest::prelude::*;
use stratasweep::io::vtk_read::{parse_vtk_legacy, parse_vtk_xml};

const LEGACY: [&[u8]; 8] = [
    include_bytes!("../fixtures/vtk/a_legacy_ascii_42.vtk"),
    include_bytes!("../fixtures/vtk/a_legacy_ascii_51.vtk"),
    include_bytes!("../fixtures/vtk/a_legacy_binary_42.vtk"),
    include_bytes!("../fixtures/vtk/a_legacy_binary_51.vtk"),
    include_bytes!("../fixtures/vtk/b_legacy_ascii_42.vtk"),
    include_bytes!("../fixtures/vtk/b_legacy_binary_51.vtk"),
    include_bytes!("../fixtures/vtk/c_legacy_ascii.vtk"),
    include_bytes!("../fixtures/vtk/c_legacy_binary.vtk"),
];

const XML: [&[u8]; 10] = [
    include_bytes!("../fixtures/vtk/a_ascii.vtu"),
    include_bytes!("../fixtures/vtk/a_base64_u64.vtu"),
    include_bytes!("../fixtures/vtk/a_appended_raw_u64.vtu"),
    include_bytes!("../fixtures/vtk/a_appended_base64_u32.vtu"),
    include_bytes!("../fixtures/vtk/a_zlib_appended_u64_blocks.vtu"),
    include_bytes!("../fixtures/vtk/a_lzma_base64_u64.vtu"),
    include_bytes!("../fixtures/vtk/a_lz4_appended_u32.vtu"),
    include_bytes!("../fixtures/vtk/b_faces_ascii.vtu"),
    include_bytes!("../fixtures/vtk/b_vtk94_ascii.vtu"),
    include_bytes!("../fixtures/vtk/c_zlib_appended.vts"),
];

/// Tokens worth inserting: huge and negative counts, keywords, markup.
const TOKENS: &[&str] = &[
    "-1",
    "0",
    "1",
    "42",
    "255",
    "256",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "18446744073709551615",
    "99999999999999999999999999",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "\n",
    " ",
    "\n\n",
    "POINTS 1000000000000 float\n",
    "CELLS 3 99999999999\n",
    "CELLS 1 1\n",
    "CELL_TYPES 4000000000\n",
    "OFFSETS vtktypeint64\n",
    "CONNECTIVITY vtktypeint64\n",
    "POINT_DATA 9\n",
    "CELL_DATA 2\n",
    "SCALARS s double 99999\n",
    "LOOKUP_TABLE t 99999999999\n",
    "FIELD f 99999999\n",
    "METADATA\n",
    "DIMENSIONS 99999999999 99999999999 99999999999\n",
    "42 42",
    "<",
    ">",
    "\"",
    "/>",
    "</DataArray>",
    "<DataArray>",
    "=",
    "_",
    "&amp;",
    "&#xFFFFFFFF;",
    " offset=\"18446744073709551615\"",
    " NumberOfComponents=\"0\"",
    "NumberOfPoints=\"99999999999\"",
    "====",
    "\u{0}\u{ff}",
];

#[derive(Clone, Debug)]
enum Mutation {
    /// Overwrite the byte at a relative position.
    Flip(usize, u8),
    /// Keep only a prefix.
    Truncate(usize),
    /// Insert a token at a relative position.
    Insert(usize, usize),
    /// Delete a run of bytes.
    Delete(usize, usize),
    /// Replace the n-th run of digits by a token.
    Number(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(a, b)| Mutation::Flip(a, b)),
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(a, t)| Mutation::Insert(a, t)),
        (any::<usize>(), 1usize..40).prop_map(|(a, n)| Mutation::Delete(a, n)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(a, t)| Mutation::Number(a, t)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(a, t)| Mutation::Number(a, t)),
    ]
}

fn apply(src: &[u8], muts: &[Mutation]) -> Vec<u8> {
    let mut b = src.to_vec();
    for m in muts {
        let len = b.len().max(1);
        match *m {
            Mutation::Flip(at, v) => {
                if !b.is_empty() {
                    let i = at % b.len();
                    b[i] = v;
                }
            }
            Mutation::Truncate(at) => b.truncate(at % len),
            Mutation::Insert(at, t) => {
                let i = at % (b.len() + 1);
                b.splice(i..i, TOKENS[t].bytes());
            }
            Mutation::Delete(at, n) => {
                let i = at % len;
                let j = (i + n).min(b.len());
                if i < j {
                    b.drain(i..j);
                }
            }
            Mutation::Number(nth, t) => {
                let runs: Vec<(usize, usize)> = digit_runs(&b);
                if !runs.is_empty() {
                    let (i, j) = runs[nth % runs.len()];
                    b.splice(i..j, TOKENS[t].bytes());
                }
            }
        }
    }
    b
}

fn digit_runs(b: &[u8]) -> Vec<(usize, usize)> {
    let mut runs = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() {
            let s = i;
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            runs.push((s, i));
        } else {
            i += 1;
        }
    }
    runs
}

/// Cases per property (override with `FUZZ_VTK_CASES` for longer runs).
fn cases() -> u32 {
    std::env::var("FUZZ_VTK_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4000)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_legacy_files_never_panic(f in 0..LEGACY.len(), muts in prop::collection::vec(mutation(), 1..6)) {
        let bytes = apply(LEGACY[f], &muts);
        if let Err(e) = parse_vtk_legacy(&bytes, "fuzz.vtk") {
            prop_assert!(e.to_string().contains("fuzz.vtk"));
        }
    }

    #[test]
    fn mutated_xml_files_never_panic(f in 0..XML.len(), muts in prop::collection::vec(mutation(), 1..6)) {
        let bytes = apply(XML[f], &muts);
        if let Err(e) = parse_vtk_xml(&bytes, "fuzz.vtu") {
            prop_assert!(e.to_string().contains("fuzz.vtu"));
        }
    }

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        let _ = parse_vtk_legacy(&bytes, "r.vtk");
        let _ = parse_vtk_xml(&bytes, "r.vtu");
    }
}

// ------------------------------------------------------------ regressions

fn legacy(s: &str) -> String {
    parse_vtk_legacy(s.as_bytes(), "reg.vtk")
        .expect_err("must fail")
        .to_string()
}

const HEAD: &str = "# vtk DataFile Version 4.2\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n";

#[test]
fn huge_header_counts_fail_fast_without_allocating() {
    let t = std::time::Instant::now();
    for s in [
        format!("{HEAD}POINTS 1000000000000 float\n0 0 0\n"),
        format!("{HEAD}POINTS 6148914691236517206 float\n0 0 0\n"),
        format!("{HEAD}POINTS 1 float\n0 0 0\nCELLS 99999999999 99999999999\n4 0 1 2 3\n"),
        format!("{HEAD}POINTS 1 float\n0 0 0\nCELLS 99999999999 1\n4\n"),
        format!("{HEAD}POINTS 1 float\n0 0 0\nCELL_TYPES 99999999999\n10\n"),
        "# vtk DataFile Version 4.2\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4611686018427387904 double\n".into(),
        "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_GRID\nDIMENSIONS 4294967296 4294967296 4294967296\nPOINTS 1 float\n0 0 0\n".into(),
    ] {
        let msg = legacy(&s);
        assert!(msg.contains("reg.vtk"), "{msg}");
    }
    assert!(t.elapsed().as_secs() < 5);
}

#[test]
fn structured_dims_overflow_is_an_error_not_a_panic() {
    // Product overflows usize; Grid::validate would overflow without the check.
    let s = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_GRID\n\
             DIMENSIONS 4294967296 4294967296 2\nPOINTS 1 float\n0 0 0\n";
    assert!(legacy(s).contains("DIMENSIONS"));
}

#[test]
fn xml_huge_block_headers_fail_fast() {
    // A zlib header claiming 2^60 blocks, and one claiming a 2^60-byte block.
    let mk = |hdr: &[u64]| {
        let raw: Vec<u8> = hdr.iter().flat_map(|w| w.to_le_bytes()).collect();
        let mut s = String::from(
            "<VTKFile type=\"UnstructuredGrid\" header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">\
             <UnstructuredGrid><Piece NumberOfPoints=\"1\" NumberOfCells=\"0\"><Points>\
             <DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"appended\" offset=\"0\"/>\
             </Points></Piece></UnstructuredGrid><AppendedData encoding=\"raw\">_",
        );
        let mut b = std::mem::take(&mut s).into_bytes();
        b.extend_from_slice(&raw);
        b.extend_from_slice(b"</AppendedData></VTKFile>");
        b
    };
    for hdr in [
        &[1u64 << 60, 16, 0][..],
        &[1, 1 << 60, 0, 8, 0x78, 0x9c, 0x03, 0, 0, 0, 0, 1][..],
    ] {
        let e = parse_vtk_xml(&mk(hdr), "hdr.vtu").unwrap_err();
        assert!(e.to_string().contains("hdr.vtu"), "{e}");
    }
}

#[test]
fn deeply_nested_or_unclosed_markup() {
    let deep = "<a>".repeat(100_000);
    assert!(parse_vtk_xml(deep.as_bytes(), "deep.vtu").is_err());
    assert!(parse_vtk_xml(b"<VTKFile type=\"UnstructuredGrid\" a=", "u.vtu").is_err());
    assert!(parse_vtk_xml(b"", "e.vtu").is_err());
    assert!(parse_vtk_legacy(b"", "e.vtk").is_err());
}
