//! Unit tests of the polyhedron checks.

use super::*;

/// The unit cube's faces, outward.
const CUBE: [[u32; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// A small deterministic generator: `next(m)` is in `0..m`.
fn lcg(mut state: u64) -> impl FnMut(u64) -> u64 {
    move |m| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) % m
    }
}

/// The edge-table pairing and the per-vertex-list pairing agree on
/// pairs, mates and errors, over cube-like cells with random face
/// orders, flipped faces, dropped faces and extra faces.
#[test]
fn edge_table_pairing_matches_the_list_pairing() {
    let mut next = lcg(11);
    let mut kinds = [0usize; 2];
    for round in 0..2000 {
        let mut faces: Vec<Vec<u32>> = CUBE.iter().map(|f| f.to_vec()).collect();
        for f in faces.iter_mut() {
            if next(4) == 0 {
                f.reverse();
            }
            let r = next(4) as usize;
            f.rotate_left(r);
        }
        match next(6) {
            0 => {
                faces.remove(next(6) as usize);
            }
            1 => faces.push(vec![0, 1, 2 + next(6) as u32]),
            _ => {}
        }
        let k = faces.len();
        for i in 0..k {
            faces.swap(i, next(k as u64) as usize);
        }
        let mut stream = vec![faces.len() as u32];
        for f in &faces {
            stream.push(f.len() as u32);
            stream.extend(f.iter().map(|&v| v * 7 + 100));
        }
        let mut a = Scratch::default();
        parse_faces_into(0, &stream, &mut a.ids, &mut a.starts).unwrap();
        local_ids(&mut a);
        let mut b = Scratch::default();
        parse_faces_into(0, &stream, &mut b.ids, &mut b.starts).unwrap();
        local_ids(&mut b);
        let (ra, rb) = (pair_edges(0, &mut a), pair_edges_by_lists(0, &mut b));
        assert_eq!(
            ra.as_ref().map_err(|e| e.to_string()),
            rb.as_ref().map_err(|e| e.to_string()),
            "round {round}: {faces:?}"
        );
        if ra.is_ok() {
            assert_eq!(a.pairs, b.pairs, "round {round}");
            assert_eq!(a.mate, b.mate, "round {round}");
        }
        kinds[ra.is_ok() as usize] += 1;
    }
    assert!(kinds[0] > 100 && kinds[1] > 100, "{kinds:?}");
}

/// The shape and duplicate checks of [`check_cell`] against a plain
/// per-face scan in face order (short face, then repeated vertex: the
/// first repeat for loops of up to 12, the smallest repeated id beyond)
/// and an all-pairs duplicate search, on cube-like cells with short
/// faces, repeated vertices, long faces and duplicate faces.
#[test]
fn shape_checks_match_a_per_face_scan() {
    let points: Vec<[f64; 3]> = (0..40)
        .map(|i| {
            [
                (i & 1) as f64,
                ((i >> 1) & 1) as f64,
                ((i >> 2) & 1) as f64 + (i >> 3) as f64 * 0.01,
            ]
        })
        .collect();
    let mut next = lcg(5);
    let mut kinds = std::collections::BTreeMap::new();
    for round in 0..4000 {
        let mut faces: Vec<Vec<u32>> = CUBE.iter().map(|f| f.to_vec()).collect();
        for _ in 0..next(3) {
            let f = next(faces.len() as u64) as usize;
            match next(5) {
                0 => faces[f].truncate(next(3) as usize),
                1 if !faces[f].is_empty() => {
                    let v = faces[f][next(faces[f].len() as u64) as usize];
                    let at = next(faces[f].len() as u64 + 1) as usize;
                    faces[f].insert(at, v);
                }
                2 => {
                    let extra = 10 + next(6) as u32;
                    faces[f].extend((0..extra).map(|i| 8 + (i + next(3) as u32 * 7) % 32));
                }
                3 => {
                    let mut d = faces[f].clone();
                    let r = next(d.len().max(1) as u64) as usize;
                    d.rotate_left(r);
                    if next(2) == 0 {
                        d.reverse();
                    }
                    let at = next(faces.len() as u64 + 1) as usize;
                    faces.insert(at, d);
                }
                _ => {
                    let g = next(faces.len() as u64) as usize;
                    faces.swap(f, g);
                }
            }
        }
        let mut stream = vec![faces.len() as u32];
        for f in &faces {
            stream.push(f.len() as u32);
            stream.extend_from_slice(f);
        }
        let mut s = Scratch::default();
        parse_faces_into(0, &stream, &mut s.ids, &mut s.starts).unwrap();
        let got = check_cell(0, &points, &mut s);
        // Reference: the per-face scan, then duplicates.
        let mut want = None;
        for (f, face) in faces.iter().enumerate() {
            if face.len() < 3 {
                want = Some(PolyhedronError::ShortFace {
                    cell: 0,
                    face: f,
                    len: face.len(),
                });
                break;
            }
            let repeated = if face.len() <= 12 {
                (1..face.len()).find_map(|i| face[..i].contains(&face[i]).then_some(face[i]))
            } else {
                let mut t = face.clone();
                t.sort_unstable();
                t.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
            };
            if let Some(vertex) = repeated {
                want = Some(PolyhedronError::RepeatedFaceVertex {
                    cell: 0,
                    face: f,
                    vertex,
                });
                break;
            }
        }
        let set = |f: &Vec<u32>| {
            let mut t = f.clone();
            t.sort_unstable();
            t
        };
        let dup = (0..faces.len())
            .any(|i| (i + 1..faces.len()).any(|j| set(&faces[i]) == set(&faces[j])));
        let kind = match (&want, &got) {
            (Some(w), Err(e)) => {
                assert_eq!(e, w, "round {round}: {faces:?}");
                "shape"
            }
            (Some(w), Ok(_)) => panic!("round {round}: {w} missed: {faces:?}"),
            (None, Err(PolyhedronError::DuplicateFace { face, other, .. })) => {
                assert!(face < other, "round {round}");
                assert_eq!(set(&faces[*face]), set(&faces[*other]), "round {round}");
                "duplicate"
            }
            (None, r) => {
                assert!(
                    !dup || r.is_err(),
                    "round {round}: duplicate missed: {faces:?}"
                );
                "other"
            }
        };
        *kinds.entry(kind).or_insert(0usize) += 1;
    }
    assert!(
        kinds.values().all(|&k| k > 100) && kinds.len() == 3,
        "{kinds:?}"
    );
}
