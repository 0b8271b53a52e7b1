//! Deterministic synthetic grids for tests and benchmarks.
//!
//! Pure functions, no I/O: every grid is a function of its size and a `u64`
//! seed only (a self-contained SplitMix64 generator, no `rand` dependency),
//! so a seed reproduces a grid bit for bit on every platform.
//!
//! * [`warped`]: a curvilinear IJK grid, smoothly warped, rotated off the
//!   axes and moved to UTM-like world coordinates (far from the origin, so
//!   f32 precision handling is exercised), carrying the Marschner–Lobb test
//!   signal as point property `f`.
//! * [`zoo`]: a conforming mixed grid of tetrahedra, pyramids, wedges and
//!   hexahedra filling the box `[-1, 1]³` exactly, carrying a noisy smooth
//!   point property `f`.
//!
//! All cells use VTK's vertex orderings with positive orientation (as
//! checked by VTK 9.7's `vtkCellValidator` / `vtkCellSizeFilter`):
//! hexahedron (12) bottom `0-1-2-3` counter-clockwise seen from the top
//! `4-5-6-7`; wedge (13) triangle `0,1,2` whose right-hand normal points
//! toward `3,4,5`; pyramid (14) base `0-1-2-3` whose right-hand normal
//! points toward the apex `4`; tetrahedron (10) with
//! `det(v1-v0, v2-v0, v3-v0) > 0`.

use crate::grid::{Cells, Grid, Property, Topology, vtk_type};
use std::f64::consts::PI;

/// World translation applied to [`warped`] grids (UTM-like easting,
/// northing, depth), so that coordinates are far from the origin.
pub const UTM_OFFSET: [f64; 3] = [4.6e5, 5.9e6, -1.7e3];

/// Marschner–Lobb modulation frequency `f_M`.
pub const ML_FREQUENCY: f64 = 6.0;

/// Marschner–Lobb amplitude `α`.
pub const ML_ALPHA: f64 = 0.25;

/// The Marschner–Lobb test signal at `p` in `[-1, 1]³`:
/// `ρ = (1 − sin(πz/2) + α(1 + ρr(√(x²+y²)))) / (2(1+α))` with
/// `ρr(r) = cos(2π f_M cos(πr/2))`, `f_M` = [`ML_FREQUENCY`], `α` = [`ML_ALPHA`].
/// The value lies in `[0, 1]`.
pub fn marschner_lobb(p: [f64; 3]) -> f64 {
    let [x, y, z] = p;
    let r = (x * x + y * y).sqrt();
    let rho_r = (2.0 * PI * ML_FREQUENCY * (PI * r / 2.0).cos()).cos();
    (1.0 - (PI * z / 2.0).sin() + ML_ALPHA * (1.0 + rho_r)) / (2.0 * (1.0 + ML_ALPHA))
}

/// SplitMix64 finaliser: a strong 64-bit mix.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in `[0, 1)` from 64 random bits.
fn unit_of(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Stateless hash of `(seed, tag, key)` to `[0, 1)`: decisions that must not
/// depend on iteration order (per column, per hex, per shared face).
fn hash_unit(seed: u64, tag: u64, key: u64) -> f64 {
    unit_of(mix64(
        mix64(seed ^ tag.wrapping_mul(0xA24B_AED4_963E_E407)) ^ key,
    ))
}

/// SplitMix64 stream.
struct SplitMix64(u64);

impl SplitMix64 {
    fn new(seed: u64, stream: u64) -> Self {
        SplitMix64(mix64(
            seed ^ mix64(stream.wrapping_add(0x9E37_79B9_7F4A_7C15)),
        ))
    }
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix64(self.0)
    }
    /// Uniform in `[a, b)`.
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * unit_of(self.next_u64())
    }
    /// `-1.0` or `1.0`.
    fn sign(&mut self) -> f64 {
        if self.next_u64() & 1 == 0 { -1.0 } else { 1.0 }
    }
}

/// Rotation matrix (row-major) of `angle` radians about the unit `axis`.
fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let [x, y, z] = axis;
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

/// A smoothly warped, rotated curvilinear grid of `dims` cells per axis
/// (`(ni+1)(nj+1)(nk+1)` points, I fastest, [`Topology::Structured`] with
/// point dims `dims + 1`).
///
/// The reference lattice spans `[-1, 1]³`; each point `u` is displaced by a
/// seed-dependent sum of sinusoids (amplitude ≤ 0.08, i.e. 4% of the
/// extent, with every entry of the displacement gradient bounded so the
/// mapping's Jacobian stays within a Gershgorin disc around the identity:
/// every cell keeps a positive Jacobian at all corners), then rotated by a
/// seed-dependent 10–30° about a tilted axis, then translated by
/// [`UTM_OFFSET`]. Point property `f` is [`marschner_lobb`] evaluated at the
/// *unwarped* reference coordinates `u`.
///
/// # Panics
/// If any of `dims` is zero.
pub fn warped(dims: [usize; 3], seed: u64) -> Grid {
    assert!(
        dims.iter().all(|&d| d > 0),
        "warped: dims must be positive, got {dims:?}"
    );
    let mut rng = SplitMix64::new(seed, 1);
    // Displacement d_a(u) = A sin(ω u_b + φ) cos(ω u_c + ψ) + B sin(ω u_a + χ),
    // (a, b, c) a cyclic permutation. |∂d_a/∂u_j| ≤ Aω, Aω, Bω per row, so
    // the row sums of the gradient are ≤ (2A + B)π ≈ 0.41 < 1.
    const A: f64 = 0.05;
    const B: f64 = 0.03;
    let phases: Vec<[f64; 3]> = (0..3)
        .map(|_| {
            [
                rng.range(0.0, 2.0 * PI),
                rng.range(0.0, 2.0 * PI),
                rng.range(0.0, 2.0 * PI),
            ]
        })
        .collect();
    // Tilted axis: every component of magnitude in [0.45, 1] before
    // normalisation, so it is at least ~32° away from each coordinate axis.
    let raw = [0, 1, 2].map(|_| rng.sign() * rng.range(0.45, 1.0));
    let norm = (raw[0] * raw[0] + raw[1] * raw[1] + raw[2] * raw[2]).sqrt();
    let axis = raw.map(|v| v / norm);
    let angle = rng.range(10.0, 30.0).to_radians() * rng.sign();
    let rot = rotation(axis, angle);

    let [ni, nj, nk] = dims;
    let n_points = (ni + 1) * (nj + 1) * (nk + 1);
    let mut points = Vec::with_capacity(n_points);
    let mut f = Vec::with_capacity(n_points);
    for k in 0..=nk {
        let uz = -1.0 + 2.0 * k as f64 / nk as f64;
        for j in 0..=nj {
            let uy = -1.0 + 2.0 * j as f64 / nj as f64;
            for i in 0..=ni {
                let ux = -1.0 + 2.0 * i as f64 / ni as f64;
                let u = [ux, uy, uz];
                f.push(marschner_lobb(u));
                let mut x = u;
                for a in 0..3 {
                    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                    let ph = phases[a];
                    x[a] += A * (PI * u[b] + ph[0]).sin() * (PI * u[c] + ph[1]).cos()
                        + B * (PI * u[a] + ph[2]).sin();
                }
                let w = [0, 1, 2].map(|r| {
                    rot[r][0] * x[0] + rot[r][1] * x[1] + rot[r][2] * x[2] + UTM_OFFSET[r]
                });
                points.push(w);
            }
        }
    }
    Grid {
        points,
        topology: Topology::Structured {
            dims: [ni + 1, nj + 1, nk + 1],
        },
        point_data: vec![Property::scalar("f", f)],
        cell_data: Vec::new(),
    }
}

/// Outward faces of a VTK hexahedron (local ids), with the lattice offset of
/// the hex across each face.
const HEX_FACES: [([usize; 4], [isize; 3]); 6] = [
    ([0, 3, 2, 1], [0, 0, -1]),
    ([4, 5, 6, 7], [0, 0, 1]),
    ([0, 1, 5, 4], [0, -1, 0]),
    ([1, 2, 6, 5], [1, 0, 0]),
    ([2, 3, 7, 6], [0, 1, 0]),
    ([3, 0, 4, 7], [-1, 0, 0]),
];

/// Expected cells per lattice hex with the probabilities used by [`zoo`]
/// (measured; used only to size the lattice).
const ZOO_CELLS_PER_HEX: f64 = 2.6;
/// Probability that a hex column is split into wedges.
const ZOO_P_WEDGE_COLUMN: f64 = 0.2;
/// Probability that a (non-wedge) hex is split into 6 pyramids.
const ZOO_P_PYRAMIDS: f64 = 0.3;
/// Probability that an eligible pyramid base is split into 2 tetrahedra.
const ZOO_P_TETS: f64 = 0.5;
/// Lattice jitter, as a fraction of the spacing, per coordinate.
const ZOO_JITTER: f64 = 0.15;

/// Key of a quad face independent of its orientation: its sorted ids packed.
fn quad_key(ids: [u32; 4]) -> u64 {
    let mut s = ids;
    s.sort_unstable();
    // Ids are < 2^32; fold them into one u64 through the mixer.
    mix64(
        mix64(mix64((s[0] as u64) << 32 | s[1] as u64) ^ s[2] as u64)
            ^ (s[3] as u64).rotate_left(17),
    )
}

/// A conforming mixed grid of about `cells` cells (tetrahedra, pyramids,
/// wedges, hexahedra) filling the box `[-1, 1]³` exactly.
///
/// Recipe: a jittered `n³` hex lattice (`n ≥ 2` chosen so the final count is
/// close to `cells`; interior lattice points move by up to 15% of the spacing
/// per coordinate, boundary points only within their boundary plane, so the
/// domain stays the box). Each hex column `(i, j)` becomes, with probability
/// 0.2, a wedge column: every hex of it splits into 2 wedges along the same
/// vertical diagonal plane. Other hexes split, with probability 0.3, into 6
/// pyramids around a new centre vertex (the mean of its corners); a pyramid
/// whose base is shared with another pyramid-split hex or lies on the
/// boundary splits into 2 tetrahedra with probability 0.5, decided per face
/// from its sorted vertex ids (so both sides agree) along the diagonal
/// through the face's smallest vertex id (so both sides use the same
/// diagonal). Every face shared by two cells therefore has the same vertex
/// set on both sides. Point property `f` is a smooth sin/cos field plus
/// `0.3 ×` uniform `[0, 1)` noise (so isosurfaces hit ambiguous faces).
/// Points are the `(n+1)³` lattice points (I fastest) followed by the
/// pyramid centres.
pub fn zoo(cells: usize, seed: u64) -> Grid {
    let n = ((cells as f64 / ZOO_CELLS_PER_HEX).cbrt().round() as usize).max(2);
    let mut points = zoo_lattice_points(n, seed);
    // Per-column and per-hex decisions (stateless hashes).
    let wedge_column: Vec<Option<bool>> = (0..n * n)
        .map(|c| {
            (hash_unit(seed, 11, c as u64) < ZOO_P_WEDGE_COLUMN)
                .then(|| hash_unit(seed, 12, c as u64) < 0.5)
        })
        .collect();
    let pyramid_split: Vec<bool> = (0..n * n * n)
        .map(|h| {
            wedge_column[h % (n * n)].is_none() && hash_unit(seed, 13, h as u64) < ZOO_P_PYRAMIDS
        })
        .collect();
    let np = n + 1;
    let lattice = |i: usize, j: usize, k: usize| (i + np * (j + np * k)) as u32;
    let mut out = Cells::default();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let c = [
                    lattice(i, j, k),
                    lattice(i + 1, j, k),
                    lattice(i + 1, j + 1, k),
                    lattice(i, j + 1, k),
                    lattice(i, j, k + 1),
                    lattice(i + 1, j, k + 1),
                    lattice(i + 1, j + 1, k + 1),
                    lattice(i, j + 1, k + 1),
                ];
                if let Some(diag02) = wedge_column[i + n * j] {
                    if diag02 {
                        out.push(vtk_type::WEDGE, &[c[0], c[1], c[2], c[4], c[5], c[6]]);
                        out.push(vtk_type::WEDGE, &[c[0], c[2], c[3], c[4], c[6], c[7]]);
                    } else {
                        out.push(vtk_type::WEDGE, &[c[0], c[1], c[3], c[4], c[5], c[7]]);
                        out.push(vtk_type::WEDGE, &[c[1], c[2], c[3], c[5], c[6], c[7]]);
                    }
                } else if pyramid_split[i + n * (j + n * k)] {
                    let hex = ZooHex {
                        ijk: [i, j, k],
                        n,
                        corners: c,
                        seed,
                    };
                    hex.push_pyramids(&pyramid_split, &mut points, &mut out);
                } else {
                    out.push(vtk_type::HEXAHEDRON, &c);
                }
            }
        }
    }
    let f = zoo_field(&points, seed);
    Grid {
        points,
        topology: Topology::Unstructured(out),
        point_data: vec![Property::scalar("f", f)],
        cell_data: Vec::new(),
    }
}

/// The `(n+1)³` jittered lattice points of [`zoo`] (I fastest; the
/// boundary stays on the box).
fn zoo_lattice_points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let np = n + 1;
    let h = 2.0 / n as f64;
    let mut rng = SplitMix64::new(seed, 2);
    let mut points = Vec::with_capacity(np * np * np);
    for k in 0..np {
        for j in 0..np {
            for i in 0..np {
                let idx = [i, j, k];
                let p = [0, 1, 2].map(|a| {
                    let base = -1.0 + 2.0 * idx[a] as f64 / n as f64;
                    let jitter = rng.range(-ZOO_JITTER, ZOO_JITTER) * h;
                    if idx[a] == 0 || idx[a] == n {
                        base
                    } else {
                        base + jitter
                    }
                });
                points.push(p);
            }
        }
    }
    points
}

/// One hexahedron of [`zoo`] split into six pyramids around its centre.
struct ZooHex {
    ijk: [usize; 3],
    n: usize,
    corners: [u32; 8],
    seed: u64,
}

impl ZooHex {
    /// Adds the centre to `points` and the six pyramids (or, on faces whose
    /// other side is split too or the boundary, a pair of tetrahedra) to `out`.
    fn push_pyramids(&self, pyramid_split: &[bool], points: &mut Vec<[f64; 3]>, out: &mut Cells) {
        let (c, n, [i, j, k]) = (self.corners, self.n, self.ijk);
        let apex = points.len() as u32;
        let centre = c.iter().fold([0.0; 3], |acc, &v| {
            let p = points[v as usize];
            [
                acc[0] + p[0] / 8.0,
                acc[1] + p[1] / 8.0,
                acc[2] + p[2] / 8.0,
            ]
        });
        points.push(centre);
        for (face, off) in HEX_FACES {
            // Base = the outward face reversed: normal toward the apex.
            let base = [c[face[0]], c[face[3]], c[face[2]], c[face[1]]];
            let ni = i as isize + off[0];
            let nj = j as isize + off[1];
            let nk = k as isize + off[2];
            let inside = [ni, nj, nk].iter().all(|&v| v >= 0 && v < n as isize);
            let eligible =
                !inside || pyramid_split[ni as usize + n * (nj as usize + n * nk as usize)];
            if eligible && hash_unit(self.seed, 14, quad_key(base)) < ZOO_P_TETS {
                let [a, b, cc, d] = base;
                let smallest = *base.iter().min().expect("4 ids");
                if smallest == a || smallest == cc {
                    out.push(vtk_type::TETRA, &[a, b, cc, apex]);
                    out.push(vtk_type::TETRA, &[a, cc, d, apex]);
                } else {
                    out.push(vtk_type::TETRA, &[a, b, d, apex]);
                    out.push(vtk_type::TETRA, &[b, cc, d, apex]);
                }
            } else {
                out.push(
                    vtk_type::PYRAMID,
                    &[base[0], base[1], base[2], base[3], apex],
                );
            }
        }
    }
}

/// The zoo grid's point property `f`: a smooth sin/cos field plus noise.
fn zoo_field(points: &[[f64; 3]], seed: u64) -> Vec<f64> {
    let mut frng = SplitMix64::new(seed, 3);
    let ph = [
        frng.range(0.0, 2.0 * PI),
        frng.range(0.0, 2.0 * PI),
        frng.range(0.0, 2.0 * PI),
    ];
    points
        .iter()
        .map(|&[x, y, z]| {
            let smooth = 0.5
                + 0.25 * (2.3 * x + ph[0]).sin() * (1.9 * y + ph[1]).cos()
                + 0.2 * (2.9 * z + 1.1 * x + ph[2]).sin();
            smooth + 0.3 * unit_of(frng.next_u64())
        })
        .collect()
}

/// A synthetic faulted corner-point reservoir of `dims` cells (NI, NJ, NK):
/// gently folded layers of varying thickness that pinch out (zero-thickness
/// corners, so wedges and collapsed cells appear), `faults` faults along
/// cell faces with throws of 5–40 m (the first vertical, the others
/// inclined, see [`faulted_with_dip`]), inactive cells (a few percent, plus
/// every cell pinched to zero thickness), slightly inclined pillars, a
/// MAPAXES to UTM-like coordinates, and a `PORO` field correlated with the
/// layers (per-layer mean and a lateral trend, plus a little noise).
///
/// Depths are rounded to millimetres, as simulators export them, so a GRDECL
/// round trip is exact. Deterministic in `(dims, faults, seed)`. No cell
/// face crosses itself: on small grids, where the fold and the thickness
/// waves would twist a face over, their wavelengths are stretched.
///
/// # Panics
/// If any of `dims` is zero.
pub fn faulted(dims: [usize; 3], faults: usize, seed: u64) -> crate::cornerpoint::CornerPointGrid {
    faulted_with_dip(dims, faults, None, seed)
}

/// Smallest fault dip [`faulted_with_dip`] accepts, in degrees.
pub const MIN_FAULT_DIP: f64 = 45.0;

/// [`faulted`] with the faults' dip chosen: `Some(d)` gives every fault
/// the dip `d` degrees (`90` = vertical, at least [`MIN_FAULT_DIP`]);
/// `None` a mix: the first fault vertical, the others dipping 50–80°.
///
/// An inclined fault dips toward the side that drops (a normal fault): the
/// pillars on its trace lean by `cot(dip)` horizontally per unit of depth,
/// anchored at the reservoir's mid depth, and the lean fades linearly away
/// from the trace over a distance long enough that no cell turns over, so
/// every fault face (spanned by two fault pillars) lies on the inclined
/// fault plane. The pillars stay straight lines (COORD top ≠ bottom).
///
/// # Panics
/// If any of `dims` is zero, or `dip` is outside `[MIN_FAULT_DIP, 90]`.
pub fn faulted_with_dip(
    dims: [usize; 3],
    faults: usize,
    dip: Option<f64>,
    seed: u64,
) -> crate::cornerpoint::CornerPointGrid {
    let [nx, ny, nz] = dims;
    assert!(nx > 0 && ny > 0 && nz > 0, "dims must be positive");
    assert!(
        dip.is_none_or(|d| (MIN_FAULT_DIP..=90.0).contains(&d)),
        "fault dip must be in [{MIN_FAULT_DIP}, 90] degrees"
    );
    let mut m = FaultedModel::new(dims, faults, dip, seed);
    let round = |v: f64| (v * 1000.0).round() / 1000.0;
    // On few cells the fold and thickness waves (sized to the extent) can
    // turn a cell's top or bottom face over itself (a twist across one cell
    // near its width) or push corners past their neighbours along leaning
    // pillars: cells with a face that crosses itself, which no convex split
    // can cut. Their lateral wavelengths are stretched until no face
    // crosses itself (grids without any keep their model unchanged).
    let (coord, zcorn, actnum, poro) = loop {
        let h = m.horizons();
        let coord: Vec<f64> = m.pillars(&h).into_iter().map(round).collect();
        let (zcorn, actnum, poro) = m.cells(&h);
        if m.relief < 1e-3 || !has_crossed_face(dims, &coord, &zcorn) {
            break (coord, zcorn, actnum, poro);
        }
        m.relief *= 0.6;
    };
    crate::cornerpoint::CornerPointGrid {
        dims,
        coord,
        zcorn,
        actnum: Some(actnum),
        mapaxes: Some([
            461_000.0,
            5_932_000.0,
            461_000.0,
            5_931_000.0,
            462_000.0,
            5_931_000.0,
        ]),
        mapunits: Some("METRES".into()),
        gridunit: Some("METRES".into()),
        properties: vec![Property::scalar("PORO", poro)],
    }
}

/// The random choices of [`faulted_with_dip`], drawn once in a fixed order
/// (so the model is deterministic in its arguments).
struct FaultedModel {
    dims: [usize; 3],
    seed: u64,
    /// Cell size along x and y.
    dx: f64,
    dy: f64,
    /// Pillar bottoms' horizontal tilt across the grid.
    tilt: [f64; 2],
    /// Fold frequencies, phases and amplitude.
    ax: f64,
    ay: f64,
    phx: f64,
    phy: f64,
    amp: f64,
    /// Mean layer thickness.
    base_t: f64,
    /// Per layer: porosity quantile and thickness wave (fx, fy, phase).
    layer_q: Vec<f64>,
    layer_f: Vec<[f64; 3]>,
    /// Faults: lines `a·i + b·j = c` in pillar-index space and their throws.
    flines: Vec<([f64; 3], f64)>,
    /// Horizontal lean per unit depth (cot dip) of each fault's pillars.
    lean: Vec<f64>,
    /// Factor on the fold's and the thickness waves' lateral frequencies
    /// (1; lowered for grids whose faces would cross themselves).
    relief: f64,
}

/// Whether a face of any cell of a corner-point grid (`coord`, `zcorn` of
/// `dims` cells) crosses itself ([`crate::structures::quad_is_bow_tie`]).
fn has_crossed_face(dims: [usize; 3], coord: &[f64], zcorn: &[f64]) -> bool {
    let [nx, ny, nz] = dims;
    let npx = nx + 1;
    // Corner q (bit 0: +i, bit 1: +j, bit 2: +k) of cell (i, j, k) on its pillar.
    let corner = |i: usize, j: usize, k: usize, q: usize| -> [f64; 3] {
        let (ii, jj, kk) = (q & 1, q >> 1 & 1, q >> 2);
        let p = &coord[6 * ((i + ii) + npx * (j + jj))..][..6];
        let z = zcorn[(2 * k + kk) * 4 * nx * ny + (2 * j + jj) * 2 * nx + 2 * i + ii];
        let s = if p[5] != p[2] {
            (z - p[2]) / (p[5] - p[2])
        } else {
            0.0
        };
        [p[0] + s * (p[3] - p[0]), p[1] + s * (p[4] - p[1]), z]
    };
    const FACES: [[usize; 4]; 6] = [
        [0, 1, 3, 2],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 3, 7, 5],
    ];
    (0..nx * ny * nz).any(|c| {
        let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
        let p: [[f64; 3]; 8] = std::array::from_fn(|q| corner(i, j, k, q));
        FACES
            .iter()
            .any(|f| crate::vec3::quad_is_bow_tie(f.map(|q| p[q])))
    })
}

impl FaultedModel {
    fn new(dims: [usize; 3], faults: usize, dip: Option<f64>, seed: u64) -> Self {
        let [nx, ny, nz] = dims;
        let mut rng = SplitMix64::new(seed, 0xFA17);
        // Pillars: tops at depth 1500, bottoms at 2500, tilted a little.
        let tilt = [rng.range(-40.0, 40.0), rng.range(-40.0, 40.0)];
        // Folding and thickness fields as functions of the pillar position.
        let (ax, ay) = (rng.range(0.6, 1.6), rng.range(0.6, 1.6));
        let (phx, phy) = (
            rng.range(0.0, std::f64::consts::TAU),
            rng.range(0.0, std::f64::consts::TAU),
        );
        let amp = rng.range(20.0, 60.0);
        let total = 120.0 + 0.5 * nz as f64;
        let layer_q: Vec<f64> = (0..nz).map(|_| rng.range(0.0, 1.0)).collect();
        let layer_f: Vec<[f64; 3]> = (0..nz)
            .map(|_| {
                [
                    rng.range(0.5, 3.0),
                    rng.range(0.5, 3.0),
                    rng.range(0.0, std::f64::consts::TAU),
                ]
            })
            .collect();
        // Faults: lines in pillar-index space; cells on the positive side drop.
        let flines: Vec<([f64; 3], f64)> = (0..faults)
            .map(|_| {
                let ang = rng.range(0.0, std::f64::consts::PI);
                let (a, b) = (ang.cos(), ang.sin());
                let (cx, cy) = (
                    rng.range(0.15, 0.85) * nx as f64,
                    rng.range(0.15, 0.85) * ny as f64,
                );
                ([a, b, a * cx + b * cy], rng.sign() * rng.range(5.0, 40.0))
            })
            .collect();
        let lean: Vec<f64> = (0..faults)
            .map(|f| {
                let d = dip.unwrap_or(if f == 0 {
                    90.0
                } else {
                    50.0 + 30.0 * hash_unit(seed, 0xD1B, f as u64)
                });
                if d >= 90.0 {
                    0.0
                } else {
                    1.0 / d.to_radians().tan()
                }
            })
            .collect();
        FaultedModel {
            dims,
            seed,
            dx: 50.0,
            dy: 50.0,
            tilt,
            ax,
            ay,
            phx,
            phy,
            amp,
            base_t: total / nz as f64,
            layer_q,
            layer_f,
            flines,
            lean,
            relief: 1.0,
        }
    }

    /// Horizontal extent along x and y.
    fn extent(&self) -> (f64, f64) {
        (self.dims[0] as f64 * self.dx, self.dims[1] as f64 * self.dy)
    }

    /// The fold's depth offset at (x, y).
    fn fold(&self, x: f64, y: f64) -> f64 {
        let (lx, ly) = self.extent();
        let (ax, ay) = (self.ax * self.relief, self.ay * self.relief);
        self.amp
            * (std::f64::consts::TAU * ax * x / lx + self.phx).sin()
            * (std::f64::consts::TAU * ay * y / ly + self.phy).cos()
            + 0.01 * x
    }

    /// Thickness of layer k at (x, y): 0 where the wave goes negative (pinched).
    fn thick(&self, k: usize, x: f64, y: f64) -> f64 {
        let (lx, ly) = self.extent();
        let [fx, fy, ph] = self.layer_f[k];
        let (fx, fy) = (fx * self.relief, fy * self.relief);
        let w = (std::f64::consts::TAU * (fx * x / lx + fy * y / ly) + ph).sin();
        (self.base_t * (1.0 + 1.3 * w)).max(0.0)
    }

    /// Summed throw of the faults whose positive side holds cell (i, j).
    fn throw_of(&self, i: usize, j: usize) -> f64 {
        self.flines
            .iter()
            .filter(|(l, _)| l[0] * (i as f64 + 0.5) + l[1] * (j as f64 + 0.5) > l[2])
            .map(|(_, t)| *t)
            .sum()
    }

    /// Horizon depths per pillar: `h[k · np + p]`, k = 0..=nz.
    fn horizons(&self) -> Vec<f64> {
        let [nx, ny, nz] = self.dims;
        let npx = nx + 1;
        let np = npx * (ny + 1);
        let mut h = vec![0.0f64; np * (nz + 1)];
        for p in 0..np {
            let (x, y) = ((p % npx) as f64 * self.dx, (p / npx) as f64 * self.dy);
            let mut d = 1600.0 + self.fold(x, y);
            h[p] = d;
            for k in 0..nz {
                d += self.thick(k, x, y);
                h[(k + 1) * np + p] = d;
            }
        }
        h
    }

    /// COORD (unrounded): the global tilt, plus the faults' lean anchored at
    /// the reservoir's mid depth `d0`. The lean fades over `fade` metres from
    /// a fault trace, so that two neighbouring pillars drift apart by at most
    /// a quarter cell within `span` (horizons and throws) of `d0`.
    fn pillars(&self, h: &[f64]) -> Vec<f64> {
        let [nx, ny, _] = self.dims;
        let (lx, ly) = self.extent();
        let (dmin, dmax) = h
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &d| (a.min(d), b.max(d)));
        let d0 = 0.5 * (dmin + dmax);
        let span = 0.5 * (dmax - dmin) + self.flines.iter().map(|f| f.1.abs()).sum::<f64>();
        let fade = (4.0 * span * self.lean.iter().sum::<f64>()).max(6.0 * self.dx);
        let max_lean = self.lean.iter().cloned().fold(0.0, f64::max);
        let mut coord = Vec::with_capacity(6 * (nx + 1) * (ny + 1));
        for pj in 0..=ny {
            for pi in 0..=nx {
                let (x, y) = (pi as f64 * self.dx, pj as f64 * self.dy);
                let s = 0.5 * ((x / lx) + (y / ly));
                // Sum of the faded leans, clipped to the steepest lean (the
                // clip keeps the drift bound, and a fault's own lean on its
                // trace where others add to it).
                let mut l = [0.0f64; 2];
                for ((f, t), &c) in self.flines.iter().zip(&self.lean) {
                    let dist = (f[0] * pi as f64 + f[1] * pj as f64 - f[2]).abs() * self.dx;
                    let w = (1.0 - dist / fade).max(0.0) * c * t.signum();
                    l[0] += w * f[0];
                    l[1] += w * f[1];
                }
                let norm = l[0].hypot(l[1]);
                let l = if norm > max_lean {
                    l.map(|v| v * max_lean / norm)
                } else {
                    l
                };
                let (up, down) = (d0 - 1500.0, 2500.0 - d0);
                coord.extend_from_slice(&[x - l[0] * up, y - l[1] * up, 1500.0]);
                coord.extend_from_slice(&[
                    x + self.tilt[0] * s + l[0] * down,
                    y + self.tilt[1] * s + l[1] * down,
                    2500.0,
                ]);
            }
        }
        coord
    }

    /// ZCORN (mm-rounded horizons plus throws), ACTNUM (pinched, random
    /// and one corner region inactive) and PORO.
    fn cells(&self, h: &[f64]) -> (Vec<f64>, Vec<u8>, Vec<f64>) {
        let [nx, ny, nz] = self.dims;
        let (npx, np) = (nx + 1, (nx + 1) * (ny + 1));
        let seed = self.seed;
        let round = |v: f64| (v * 1000.0).round() / 1000.0;
        let mut zcorn = vec![0.0; 8 * nx * ny * nz];
        let mut actnum = vec![1u8; nx * ny * nz];
        let mut poro = vec![0.0; nx * ny * nz];
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let t = self.throw_of(i, j);
                    let c = i + nx * (j + ny * k);
                    let mut pinched = true;
                    for corner in 0..8 {
                        let (ii, jj, kk) = (corner & 1, corner >> 1 & 1, corner >> 2);
                        let p = (i + ii) + npx * (j + jj);
                        let z = (2 * k + kk) * 4 * nx * ny + (2 * j + jj) * 2 * nx + 2 * i + ii;
                        zcorn[z] = round(h[(k + kk) * np + p] + t);
                        if kk == 1 && zcorn[z] != zcorn[z - 4 * nx * ny] {
                            pinched = false;
                        }
                    }
                    let r = hash_unit(seed, 0xAC7, c as u64);
                    if pinched || r < 0.02 || (i < nx / 8 && j < ny / 8) {
                        actnum[c] = 0;
                    }
                    let trend = 0.05 * ((i as f64 / nx as f64) - (j as f64 / ny as f64));
                    let noise = 0.02 * (hash_unit(seed, 0x9090, c as u64) - 0.5);
                    poro[c] = (0.08 + 0.22 * self.layer_q[k] + trend + noise).clamp(0.01, 0.4);
                    poro[c] = (poro[c] * 1e4).round() / 1e4;
                }
            }
        }
        (zcorn, actnum, poro)
    }
}
