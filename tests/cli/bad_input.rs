//! Issue 17: bad input never destroys data, never crashes or hangs, never
//! passes in silence. One test per class; every fixture is written by the
//! test into its own folder, and every input file is checked byte for byte
//! after each run.

use std::path::PathBuf;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use crate::support;
use crate::support::Dir;

use stratasweep::cornerpoint::CornerPointGrid;
use stratasweep::io::egrid::{EclData, write_array};
use stratasweep::io::egrid_write::write_egrid;

/// A folder of fixtures whose files are checked byte for byte.
trait Refuses {
    /// Runs the binary; asserts it failed cleanly with `msg` in its error,
    /// and that the folder's files are exactly as before (nothing written,
    /// nothing changed, no temporary file left).
    fn refused(&self, args: &[&str], msg: &str) -> String;
}

impl Refuses for Dir {
    fn refused(&self, args: &[&str], msg: &str) -> String {
        let before = self.snapshot();
        let o = run(args);
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(msg), "{args:?}: expected '{msg}' in: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(self.snapshot(), before, "{args:?} changed the folder");
        err
    }
}

/// Runs the binary quietly, killed after 60 s (a hang fails the test).
fn run(args: &[&str]) -> Output {
    run_within(args, Duration::from_secs(60)).unwrap_or_else(|| panic!("{args:?} hung"))
}

fn run_within(args: &[&str], limit: Duration) -> Option<Output> {
    support::output_within(
        support::bin()
            .args(args)
            .arg("--quiet")
            .env("NODEVICE_SELECT", "1")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped()),
        limit,
    )
}

/// A 2×1×1 corner-point grid: COORD in an INCLUDE, ZCORN inline.
fn deck(d: &Dir) -> PathBuf {
    d.write(
        "coord.inc",
        "COORD\n0 0 0 0 0 1  1 0 0 1 0 1  2 0 0 2 0 1\n0 1 0 0 1 1  1 1 0 1 1 1  2 1 0 2 1 1 /\n",
    );
    d.write(
        "grid.grdecl",
        "SPECGRID\n2 1 1 1 F /\nINCLUDE\n'coord.inc' /\nZCORN\n8*0 8*1 /\nPORO\n0.1 0.2 /\n",
    )
}

/// An ASCII legacy VTK 2×2×2-point structured grid with point property f.
fn vtk_cube(f: &[f64; 8]) -> String {
    let f: Vec<String> = f.iter().map(|x| x.to_string()).collect();
    format!(
        "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_GRID\nDIMENSIONS 2 2 2\nPOINTS 8 double\n\
         0 0 0 1 0 0 0 1 0 1 1 0 0 0 1 1 0 1 0 1 1 1 1 1\nPOINT_DATA 8\nSCALARS f double 1\nLOOKUP_TABLE default\n{}\n",
        f.join(" ")
    )
}

fn cornerpoint_2x1x1() -> CornerPointGrid {
    let mut coord = Vec::new();
    for j in 0..2 {
        for i in 0..3 {
            coord.extend([i as f64, j as f64, 0.0, i as f64, j as f64, 1.0]);
        }
    }
    let mut zcorn = vec![0.0; 8];
    zcorn.extend([1.0; 8]);
    CornerPointGrid {
        dims: [2, 1, 1],
        coord,
        zcorn,
        actnum: None,
        mapaxes: None,
        mapunits: None,
        gridunit: None,
        properties: Vec::new(),
    }
}

#[test]
fn class1_an_output_never_names_an_input() {
    let d = Dir::new("bad-input-class1");
    let g = deck(&d);
    let gs = g.display().to_string();
    let stats_on_grid = d.refused(
        &[
            "slice",
            &gs,
            "--axis",
            "z",
            "--count",
            "3",
            "-o",
            &d.s("out.vtp"),
            "--stats",
            &gs,
        ],
        "refusing to write --stats",
    );
    assert!(stats_on_grid.contains("the grid file"), "{stats_on_grid}");
    // The INCLUDE, known only once the deck is read: refused before writing.
    let e = d.refused(
        &[
            "slice",
            &gs,
            "--axis",
            "z",
            "--count",
            "3",
            "-o",
            &d.s("out.vtp"),
            "--stats",
            &d.s("coord.inc"),
        ],
        "refusing to write --stats",
    );
    assert!(e.contains("a file the grid reads (INCLUDE or INIT)"), "{e}");
    // Two outputs, one file (./ spelling).
    let same = d.s("same.vtp");
    let dotted = format!("{}/./same.vtp", d.0.display());
    d.refused(
        &[
            "slice", &gs, "--axis", "z", "--count", "3", "-o", &same, "--stats", &dotted,
        ],
        "name the same file",
    );
    // A symbolic link to the grid.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&g, d.0.join("link.grdecl")).unwrap();
        d.refused(
            &[
                "slice",
                &gs,
                "--axis",
                "z",
                "--count",
                "3",
                "--stats",
                &d.s("link.grdecl"),
            ],
            "it is the grid file",
        );
    }
    // render: the grid, and the transfer function (checked before any GPU work).
    let v = d.write("cube.vtk", vtk_cube(&[0., 1., 2., 3., 4., 5., 6., 7.]));
    let vs = v.display().to_string();
    d.refused(&["render", &vs, "-o", &vs], "it is the grid file");
    let tf = d.write(
        "tf.json",
        r#"{"points":[{"value":0,"color":[1,0,0],"opacity":1}]}"#,
    );
    let tfs = tf.display().to_string();
    d.refused(
        &["render", &vs, "-o", &tfs, "--transfer", &tfs],
        "it is the transfer function",
    );
    // EGRID: the INIT beside it.
    let mut b = Vec::new();
    write_egrid(&mut b, &cornerpoint_2x1x1()).unwrap();
    let eg = d.write("m.EGRID", &b);
    let mut init = Vec::new();
    write_array(&mut init, "PORO", &EclData::Real(vec![0.1, 0.2])).unwrap();
    d.write("m.INIT", &init);
    d.refused(
        &[
            "slice",
            &eg.display().to_string(),
            "--axis",
            "z",
            "--count",
            "2",
            "--stats",
            &d.s("m.INIT"),
        ],
        "the INIT file read with the grid",
    );
    // And a good run writes both outputs, atomically (no temporary left).
    let o = run(&[
        "slice",
        &gs,
        "--axis",
        "z",
        "--count",
        "3",
        "-o",
        &d.s("ok.vtp"),
        "--stats",
        &d.s("ok.json"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names: Vec<String> = d.snapshot().into_keys().collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
    assert!(names.contains(&"ok.vtp".into()) && names.contains(&"ok.json".into()));
}

#[test]
fn class1_atomic_file_replaces_only_on_commit() {
    use std::io::Write;
    let d = Dir::new("bad-input-atomic");
    let p = d.write("a.txt", "old");
    {
        let mut f = stratasweep::io::atomic::AtomicFile::create(&p).unwrap();
        f.write_all(b"half a fi").unwrap();
        // Dropped without commit: an interrupted write.
    }
    assert_eq!(std::fs::read(&p).unwrap(), b"old");
    assert_eq!(d.snapshot().len(), 1, "the temporary file was removed");
    let mut f = stratasweep::io::atomic::AtomicFile::create(&p).unwrap();
    f.write_all(b"new").unwrap();
    f.commit().unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), b"new");
    assert_eq!(d.snapshot().len(), 1);
}

#[test]
fn class2_one_argument_never_crashes_or_hangs() {
    let d = Dir::new("bad-input-class2");
    let g = deck(&d).display().to_string();
    let t = Instant::now();
    let e = d.refused(
        &["slice", &g, "--axis", "z", "--values", "0:10:1e-9"],
        "gives 10000000001 levels, more than the limit of 100000",
    );
    assert!(e.contains("--values"), "{e}");
    d.refused(
        &["slice", &g, "--axis", "z", "--values=-1e300:1e300:1e290"],
        "more than the limit of 100000",
    );
    d.refused(
        &["slice", &g, "--axis", "z", "--count", "10000000"],
        "--count 10000000 is more than the limit of 100000 levels",
    );
    d.refused(
        &[
            "slice",
            &g,
            "--axis",
            "z",
            "--count",
            "3",
            "--threads",
            "1000000",
        ],
        "--threads 1000000 is more than the limit of",
    );
    d.refused(&["bench", &g, "--count", "10000000"], "--count 10000000");
    let v = d.write("cube.vtk", vtk_cube(&[0., 1., 2., 3., 4., 5., 6., 7.]));
    let vs = v.display().to_string();
    let png = d.s("r.png");
    d.refused(
        &["render", &vs, "-o", &png, "--slices", "100000000"],
        "--slices 100000000 is outside 1..=8192",
    );
    d.refused(
        &["render", &vs, "-o", &png, "--size", "100000x100000"],
        "each side must be a whole number in 1..=8192",
    );
    d.refused(
        &["render", &vs, "-o", &png, "--size", "99999999999x1"],
        "--size",
    );
    assert!(t.elapsed() < Duration::from_secs(30), "{:?}", t.elapsed());
    // A 54-byte deck claiming 800³ cells, then EQUALS: refused in little
    // memory (under a 1.5 GB address-space cap it used to abort).
    let big = d.write(
        "big.DATA",
        "RUNSPEC\nDIMENS\n800 800 800 /\nGRID\nEQUALS\nPORO 0.2 /\n/\n",
    );
    let script = format!(
        "ulimit -v 1500000; exec {} info {} --quiet",
        env!("CARGO_BIN_EXE_stratasweep"),
        big.display()
    );
    let before = d.snapshot();
    let o = Command::new("sh").args(["-c", &script]).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("before COORD and ZCORN were read"), "{err}");
    assert_eq!(d.snapshot(), before);
}

#[test]
fn class3_init_arrays_skipped_are_reported() {
    let d = Dir::new("bad-input-init");
    let mut b = Vec::new();
    write_egrid(&mut b, &cornerpoint_2x1x1()).unwrap();
    let eg = d.write("m.EGRID", &b).display().to_string();
    let mut init = Vec::new();
    write_array(&mut init, "PORO", &EclData::Real(vec![0.1, 0.2, 0.3])).unwrap();
    write_array(&mut init, "PERMX", &EclData::Real(vec![1.0, f32::NAN])).unwrap();
    write_array(&mut init, "NTG", &EclData::Real(vec![0.5, 0.6])).unwrap();
    d.write("m.INIT", &init);
    let before = d.snapshot();
    let o = run(&["info", &eg, "--json"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("warning: ")
            && err.contains("array PORO skipped: has 3 values; the grid has 2 cells"),
        "{err}"
    );
    assert!(
        err.contains("array PERMX skipped: value 1 is NaN (not finite)"),
        "{err}"
    );
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let skipped = &j["cornerpoint"]["input"]["skipped_init_arrays"];
    assert_eq!(skipped.as_array().unwrap().len(), 2, "{skipped}");
    assert_eq!(skipped[0]["name"], "PORO");
    assert_eq!(j["cell_properties"], serde_json::json!(["NTG"]));
    assert_eq!(d.snapshot(), before);
}

#[test]
fn class3_little_endian_binary_vtk_is_refused_naming_the_byte_order() {
    let d = Dir::new("bad-input-endian");
    let mut le = b"# vtk DataFile Version 3.0\nt\nBINARY\nDATASET STRUCTURED_GRID\nDIMENSIONS 2 2 2\nPOINTS 8 float\n".to_vec();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..2 {
                for x in [i, j, k] {
                    le.extend((x as f32 + 100.0).to_le_bytes());
                }
            }
        }
    }
    le.push(b'\n');
    let f = d.write("le.vtk", &le).display().to_string();
    d.refused(&["info", &f], "POINTS look little-endian");
    d.refused(
        &["slice", &f, "--axis", "z", "--count", "2"],
        "Rewrite the file big-endian",
    );
    // The same file big-endian loads.
    let be: Vec<u8> = le[..le.len() - 97].to_vec();
    let mut be = be;
    for c in le[le.len() - 97..le.len() - 1].chunks(4) {
        be.extend(c.iter().rev());
    }
    be.push(b'\n');
    let f = d.write("be.vtk", &be).display().to_string();
    assert!(run(&["info", &f]).status.success());
}

#[test]
fn class3_outputs_are_written_in_the_format_the_extension_names() {
    let d = Dir::new("bad-input-formats");
    let vtu = d.s("f.vtu");
    let o = run(&["generate", "faulted", "--dims", "10,10,4", "-o", &vtu]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read(&vtu).unwrap();
    assert!(
        text.starts_with(b"<?xml")
            && String::from_utf8_lossy(&text[..400]).contains("UnstructuredGrid")
    );
    let eg = d.s("f.EGRID");
    assert!(
        run(&["generate", "faulted", "--dims", "10,10,4", "-o", &eg])
            .status
            .success()
    );
    assert_eq!(&std::fs::read(&eg).unwrap()[..12], b"\0\0\0\x10FILEHEAD");
    assert!(
        d.0.join("f.INIT").is_file(),
        "PORO goes to the INIT beside it"
    );
    let j = |p: &str| -> serde_json::Value {
        serde_json::from_slice(&run(&["info", p, "--json"]).stdout).unwrap()
    };
    let gr = d.s("f.grdecl");
    assert!(
        run(&["generate", "faulted", "--dims", "10,10,4", "-o", &gr])
            .status
            .success()
    );
    for p in [&vtu, &eg] {
        assert_eq!(j(p)["cells"], j(&gr)["cells"], "{p}");
        assert_eq!(j(p)["cell_properties"], serde_json::json!(["PORO"]), "{p}");
    }
    d.refused(
        &[
            "generate",
            "faulted",
            "--dims",
            "2,2,2",
            "-o",
            &d.s("x.txt"),
        ],
        "-o ",
    );
    let e = d.refused(
        &[
            "generate",
            "faulted",
            "--dims",
            "2,2,2",
            "-o",
            &d.s("x.vts"),
        ],
        "cannot write this file type",
    );
    assert!(e.contains(".grdecl, .inc, .vtu, .egrid"), "{e}");
    d.refused(
        &["generate", "zoo", "--cells", "10", "-o", &d.s("z.grdecl")],
        "must be one of .vtu",
    );
    d.refused(
        &[
            "slice",
            &gr,
            "--axis",
            "z",
            "--count",
            "2",
            "-o",
            &d.s("m.obj"),
        ],
        "must be one of .ply, .vtp",
    );
    d.refused(&["render", &gr, "-o", &d.s("r.jpg")], "must be one of .png");
}

#[test]
fn class3_messages_name_the_real_cause() {
    let d = Dir::new("bad-input-messages");
    let t = d
        .write("t.EGRID", "SPECGRID\n2 2 2 1 F /\n")
        .display()
        .to_string();
    d.refused(&["info", &t], "not an EGRID file: it looks like text");
    std::fs::create_dir(d.0.join("sub")).unwrap();
    let inc = d
        .write("inc.grdecl", "SPECGRID\n1 1 1 1 F /\nINCLUDE\n'sub' /\n")
        .display()
        .to_string();
    d.refused(&["info", &inc], "'sub' is a directory");
    let bx = d
        .write(
            "box.grdecl",
            "SPECGRID\n2 2 2 1 F /\nEQUALS\nPORO 0.2 1 2000000000 /\n/\n",
        )
        .display()
        .to_string();
    d.refused(
        &["info", &bx],
        "box index 2000000000 is out of range: I runs from 1 to 2",
    );
    let flat = d
        .write(
            "flat.grdecl",
            "SPECGRID\n2 1 1 1 F /\nCOORD\n0 0 0 0 0 1  1 0 0 1 0 1  2 0 0 2 0 1\n0 1 0 0 1 1  1 1 0 1 1 1  2 1 0 2 1 1 /\nZCORN\n16*0 /\n",
        )
        .display()
        .to_string();
    d.refused(
        &["info", &flat],
        "no cells left: of the 2 cells, 2 dropped as degenerate",
    );
    let far = vtk_cube(&[0.; 8]).replace("1 1 1\nPOINT", "1e39 1 1\nPOINT");
    let far = d.write("far.vtk", far).display().to_string();
    d.refused(
        &["slice", &far, "--axis", "z", "--count", "2"],
        "coordinates beyond the f32 range: point 7 has x=1e39",
    );
    let dm = vtk_cube(&[0.; 8])
        .replace("POINTS 8", "POINTS 9")
        .replace("1 1 1\nPOINT", "1 1 1 0 0 0\nPOINT");
    let dm = d.write("dm.vtk", dm).display().to_string();
    d.refused(
        &["info", &dm],
        "dm.vtk:6: POINTS 9, but DIMENSIONS 2 2 2 give 8 points",
    );
    // Control bytes quoted from a file come out escaped.
    let ctl = d
        .write("ctl.vtk", b"# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 fl\0\x1boat\n")
        .display()
        .to_string();
    let e = d.refused(&["info", &ctl], "data type 'fl\\u{0}\\u{1b}oat'");
    assert!(e.bytes().all(|b| b >= 0x20 || b == b'\n'), "{e:?}");
}

#[test]
fn class3_blank_renders_are_refused() {
    let d = Dir::new("bad-input-blank");
    let v = d
        .write("cube.vtk", vtk_cube(&[0., 1., 2., 3., 4., 5., 6., 7.]))
        .display()
        .to_string();
    let png = d.s("r.png");
    let tf = d.write("tf.json", r#"{"points":[]}"#).display().to_string();
    d.refused(
        &["render", &v, "-o", &png, "--transfer", &tf],
        "the transfer function has no points",
    );
    let tf0 = d
        .write(
            "tf0.json",
            r#"{"points":[{"value":0,"color":[1,0,0],"opacity":0}]}"#,
        )
        .display()
        .to_string();
    d.refused(
        &["render", &v, "-o", &png, "--transfer", &tf0],
        "every transfer point has opacity 0",
    );
    let c = d
        .write("const.vtk", vtk_cube(&[3.; 8]))
        .display()
        .to_string();
    d.refused(&["render", &c, "-o", &png], "property 'f' is constant (3)");
    d.refused(
        &["render", &v, "-o", &png, "--mode", "iso", "--iso", "100,-5"],
        "every isovalue is outside the range of 'f'",
    );
}

#[test]
fn class3_a_bow_tie_hexahedron_is_named_and_decomposed() {
    let d = Dir::new("bad-input-bowtie");
    let pts = "0 0 0 1 0 0 1 1 0 0 1 0 0 0 1 1 0 1 1 1 1 0 1 1 2 0 0 2 1 0 2 0 1 2 1 1";
    let cube = |first: &str| {
        format!(
            "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 12 double\n{pts}\n\
             CELLS 2 18\n8 {first}\n8 1 8 9 2 5 10 11 6\nCELL_TYPES 2\n12\n12\n\
             POINT_DATA 12\nSCALARS f double 1\nLOOKUP_TABLE default\n0 1 2 3 4 5 6 7 8 9 10 11\n"
        )
    };
    let ok = d
        .write("ok.vtk", cube("0 1 2 3 4 5 6 7"))
        .display()
        .to_string();
    // Vertices 2 and 3 swapped: the bottom and back faces cross themselves.
    let bad = d
        .write("bowtie.vtk", cube("0 1 3 2 4 5 6 7"))
        .display()
        .to_string();
    let info = |f: &str| -> serde_json::Value {
        let o = run(&["info", f, "--json"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    // The same good cube as a voxel (VTK's voxel corner order) is not flagged.
    let voxel = cube("0 1 3 2 4 5 7 6").replace("CELL_TYPES 2\n12\n", "CELL_TYPES 2\n11\n");
    let voxel = d.write("voxel.vtk", voxel).display().to_string();
    let before = d.snapshot();
    let v = info(&voxel);
    assert_eq!(v["cell_types"]["voxel"], 1, "{}", v["cell_types"]);
    assert_eq!(v["self_intersecting_cells"]["count"], 0);
    assert_eq!(v["cell_classes"]["valid"], 2);
    let (a, b) = (info(&ok), info(&bad));
    assert_eq!(a["cell_classes"]["self_intersecting"], 0);
    assert_eq!(a["cell_classes"]["valid"], 2);
    // The twisted cell is named, and sliced through its tetrahedral
    // decomposition (tests/twisted_cells.rs), not dropped.
    assert_eq!(
        b["cell_classes"]["self_intersecting"], 0,
        "{}",
        b["cell_classes"]
    );
    assert_eq!(b["live_cells"], 2);
    assert_eq!(b["cell_treatment"]["twisted_decomposed"], 1);
    assert_eq!(
        b["self_intersecting_cells"],
        serde_json::json!({"count": 1, "first": [0]})
    );
    let o = run(&["info", &bad]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains(
            "self-intersecting cells (a face crosses itself; sliced through a tetrahedral decomposition): 1, first ids [0]"
        ),
        "{text}"
    );
    // Both cells are sliced, and slice says how the twisted one was.
    let stats = d.s("s.json");
    let o = run(&[
        "slice", &bad, "--axis", "x", "--count", "4", "--stats", &stats,
    ]);
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("note: 1 cell(s) with a face that crosses itself (a bow-tie) sliced"),
        "{err}"
    );
    let s: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    std::fs::remove_file(&stats).unwrap();
    assert_eq!(s["cell_treatment"]["twisted_decomposed"], 1, "{s}");
    // Levels at x = 0.25, 0.75 cut the twisted cell only (nothing before).
    assert!(
        s["slices"]
            .as_array()
            .unwrap()
            .iter()
            .all(|l| l["cells"] == 1 && l["area"].as_f64() > Some(0.5)),
        "{s}"
    );
    assert_eq!(d.snapshot(), before);
}

#[test]
fn class3_bow_tie_test_against_simple_quads() {
    use stratasweep::structures::quad_is_bow_tie;
    let sq = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
    assert!(!quad_is_bow_tie(sq));
    // Concave (a dart) and warped quads are simple.
    assert!(!quad_is_bow_tie([
        [0., 0., 0.],
        [2., 0., 0.],
        [0.5, 0.5, 0.],
        [0., 2., 0.]
    ]));
    assert!(!quad_is_bow_tie([
        [0., 0., 0.],
        [1., 0., 0.3],
        [1., 1., 0.],
        [0., 1., 0.3]
    ]));
    // Two vertices swapped: crosses itself.
    assert!(quad_is_bow_tie([sq[0], sq[1], sq[3], sq[2]]));
    // Collapsed (two points equal) is not a bow-tie (repeated vertex instead).
    assert!(!quad_is_bow_tie([sq[0], sq[1], sq[1], sq[3]]));
}

/// Two unit cubes as VTK polyhedra, the second shifted along x; `flip`
/// reverses that cube's first face loop (given inward).
fn two_polyhedra(flip: bool) -> stratasweep::grid::Grid {
    use stratasweep::grid::{Cells, Grid, Topology};
    let mut points: Vec<[f64; 3]> = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect();
    points.extend((0..8).map(|i| {
        [
            2.0 + (i & 1) as f64,
            ((i >> 1) & 1) as f64,
            ((i >> 2) & 1) as f64,
        ]
    }));
    let cube = |o: u32| -> Vec<Vec<u32>> {
        [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ]
        .iter()
        .map(|f| f.iter().map(|v| v + o).collect())
        .collect()
    };
    let mut cells = Cells::default();
    cells.push_polyhedron(&cube(0));
    let mut second = cube(8);
    if flip {
        second[0].reverse();
    }
    cells.push_polyhedron(&second);
    Grid {
        points,
        topology: Topology::Unstructured(cells),
        point_data: vec![],
        cell_data: vec![],
    }
}

#[test]
fn class3_a_face_given_inward_is_reported_as_reoriented() {
    let d = Dir::new("bad-input-inward");
    let ok = d.s("ok.vtu");
    let bad = d.s("inward.vtu");
    stratasweep::io::writers::write_vtk_xml_grid(&ok, &two_polyhedra(false)).unwrap();
    stratasweep::io::writers::write_vtk_xml_grid(&bad, &two_polyhedra(true)).unwrap();
    let before = d.snapshot();
    let info = |f: &str| -> serde_json::Value {
        let o = run(&["info", f, "--json"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    assert_eq!(
        info(&ok)["reoriented_polyhedra"],
        serde_json::json!({"count": 0, "faces": 0, "first": []})
    );
    let b = info(&bad);
    assert_eq!(
        b["reoriented_polyhedra"],
        serde_json::json!({"count": 1, "faces": 1, "first": [1]})
    );
    // Re-oriented, both cubes are valid and sliced whole.
    assert_eq!(b["live_cells"], 2, "{b}");
    let text = String::from_utf8_lossy(&run(&["info", &bad]).stdout).to_string();
    assert!(
        text.contains("polyhedra with faces given inward (re-oriented outward before slicing): 1, 1 faces, first ids [1]"),
        "{text}"
    );
    assert_eq!(d.snapshot(), before);
}
