//! Pieces shared by the legacy and XML readers: scalar types, binary and ASCII
//! number decoding (floats: [`crate::io::number`]), and assembly of [`Cells`] from VTK's flat arrays.

use super::VtkReadError;
use crate::grid::{Cells, Grid, Topology, vtk_type};
use crate::io::number::parse_decimal;
use crate::mem::split_lengths;
use crate::mem::{try_filled, try_vec};

pub(crate) use super::decode::{decode_f64, decode_i64, decode_u32_ids};

/// A VTK scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Scalar {
    /// Packed bits (legacy `bit`).
    Bit,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    /// Bytes per value (0 for packed bits).
    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::Bit => 0,
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    /// Legacy type names, as written by `vtkDataWriter` (case-insensitive).
    /// `vtkIdType` is written as a 4-byte int in legacy binary files.
    pub(crate) fn from_legacy(name: &[u8]) -> Option<Scalar> {
        let n = name.to_ascii_lowercase();
        Some(match n.as_slice() {
            b"bit" => Scalar::Bit,
            b"char" | b"signed_char" | b"vtktypeint8" => Scalar::I8,
            b"unsigned_char" | b"vtktypeuint8" => Scalar::U8,
            b"short" | b"vtktypeint16" => Scalar::I16,
            b"unsigned_short" | b"vtktypeuint16" => Scalar::U16,
            b"int" | b"vtkidtype" | b"vtktypeint32" => Scalar::I32,
            b"unsigned_int" | b"vtktypeuint32" => Scalar::U32,
            b"long" | b"long_long" | b"__int64" | b"vtktypeint64" => Scalar::I64,
            b"unsigned_long" | b"unsigned_long_long" | b"unsigned___int64" | b"vtktypeuint64" => {
                Scalar::U64
            }
            b"float" | b"vtktypefloat32" => Scalar::F32,
            b"double" | b"vtktypefloat64" => Scalar::F64,
            _ => return None,
        })
    }

    /// XML `type` attribute values.
    pub(crate) fn from_xml(name: &str) -> Option<Scalar> {
        Some(match name {
            "Int8" | "Char" => Scalar::I8,
            "UInt8" | "UChar" => Scalar::U8,
            "Int16" => Scalar::I16,
            "UInt16" => Scalar::U16,
            "Int32" => Scalar::I32,
            "UInt32" => Scalar::U32,
            "Int64" => Scalar::I64,
            "UInt64" => Scalar::U64,
            "Float32" => Scalar::F32,
            "Float64" => Scalar::F64,
            _ => return None,
        })
    }
}

/// ASCII whitespace as understood by C's `isspace`.
#[inline]
pub(crate) fn is_ws(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c)
}

/// Parses an integer token; integral floating-point tokens (`4.0`, `1e3`)
/// are accepted too.
pub(crate) fn parse_i64(s: &[u8]) -> Option<i64> {
    let (neg, digits) = match s.first()? {
        b'-' => (true, &s[1..]),
        b'+' => (false, &s[1..]),
        _ => (false, s),
    };
    if !digits.is_empty() && digits.iter().all(u8::is_ascii_digit) {
        let mut v: i64 = 0;
        for &c in digits {
            v = v.checked_mul(10)?.checked_add(i64::from(c - b'0'))?;
        }
        return Some(if neg { -v } else { v });
    }
    let f = parse_decimal(s)?;
    if f.is_finite() && f.fract() == 0.0 && (-9.2e18..=9.2e18).contains(&f) {
        Some(f as i64)
    } else {
        None
    }
}

/// Decodes `%XX` escapes that VTK writes in legacy array names.
pub(crate) fn decode_name(raw: &[u8]) -> String {
    let mut out = Vec::with_capacity(raw.len());
    let mut i = 0;
    while i < raw.len() {
        if raw[i] == b'%' {
            let hex = raw
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok());
            if let Some(b) = hex {
                out.push(b);
                i += 3;
                continue;
            }
        }
        out.push(raw[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Where the faces of polyhedra come from.
pub(crate) enum PolyFaces<'a, T> {
    /// The connectivity entry of a polyhedron is its legacy face stream
    /// (`nf, n0, ids.., n1, ids..`), as VTK's legacy writer stores it.
    InConnectivity,
    /// A separate face stream per cell (`None` for cells without one).
    Streams {
        /// All face streams, concatenated.
        stream: &'a [T],
        /// Per cell, the range of its face stream in `stream`.
        ranges: &'a [Option<(usize, usize)>],
    },
}

fn point_id(v: i64) -> Result<u32, String> {
    match u32::try_from(v) {
        Ok(id) if id < u32::MAX => Ok(id),
        _ if v < 0 => Err(format!("negative point id {v}")),
        _ => Err(format!("point id {v} exceeds the u32 id range")),
    }
}

/// A face-stream value as read: i64, or u32 when the reader could narrow
/// the whole array on the way in.
pub(crate) trait StreamValue: Copy {
    /// The value as i64 (exact).
    fn to_i64(self) -> i64;
}

impl StreamValue for i64 {
    #[inline(always)]
    fn to_i64(self) -> i64 {
        self
    }
}

impl StreamValue for u32 {
    #[inline(always)]
    fn to_i64(self) -> i64 {
        i64::from(self)
    }
}

/// Appends a legacy face stream to `out` (converted to u32); checks that
/// every value fits and that the stream is exactly consumed.
fn push_face_stream<T: StreamValue>(s: &[T], out: &mut Vec<u32>) -> Result<(), String> {
    // Fast path: every value checked at once (branch-free), the stream
    // copied whole, then its face counts walked; any failure reruns the
    // entry-by-entry path below for its precise message.
    let first = out.len();
    if s.iter()
        .fold(true, |ok, &v| ok & ((v.to_i64() as u64) < u32::MAX as u64))
    {
        out.extend(s.iter().map(|&v| v.to_i64() as u32));
        let st = &out[first..];
        if let Some((&nf, _)) = st.split_first() {
            let mut i = 1usize;
            let mut faces = 0u32;
            while faces < nf && i < st.len() {
                i += 1 + st[i] as usize;
                faces += 1;
            }
            if faces == nf && i == st.len() {
                return Ok(());
            }
        }
        out.truncate(first);
    }
    let wide: Vec<i64> = s.iter().map(|&v| v.to_i64()).collect();
    push_face_stream_checked(&wide, out).inspect_err(|_| out.truncate(first))
}

/// [`push_face_stream`] entry by entry, naming the first bad entry.
fn push_face_stream_checked(s: &[i64], out: &mut Vec<u32>) -> Result<(), String> {
    let Some((&nf, mut rest)) = s.split_first() else {
        return Err("polyhedron with an empty face stream".into());
    };
    let nfu = u32::try_from(nf).map_err(|_| format!("polyhedron face count {nf} out of range"))?;
    out.push(nfu);
    for f in 0..nfu {
        let Some((&k, r)) = rest.split_first() else {
            return Err(format!(
                "polyhedron face stream ends before face {f} of {nf}"
            ));
        };
        let ku =
            usize::try_from(k).map_err(|_| format!("polyhedron face {f} has vertex count {k}"))?;
        let Some(ids) = r.get(..ku) else {
            return Err(format!(
                "polyhedron face {f}: expected {ku} vertex ids, found {} values left in the face stream",
                r.len()
            ));
        };
        out.push(ku as u32);
        for &v in ids {
            out.push(point_id(v)?);
        }
        rest = &r[ku..];
    }
    if !rest.is_empty() {
        return Err(format!(
            "polyhedron face stream: expected {nf} faces, found {} trailing values",
            rest.len()
        ));
    }
    Ok(())
}

/// Distinct values of short id lists in linear time: a small open-addressed
/// table whose slots are cleared by a generation count, not by a sweep.
/// (A polyhedron's face stream names each vertex about three times; sorting
/// all of it to drop the repeats cost more than the rest of the read.)
struct Distinct {
    keys: Box<[u32; Distinct::SLOTS]>,
    gens: Box<[u32; Distinct::SLOTS]>,
    generation: u32,
}

impl Default for Distinct {
    fn default() -> Self {
        Distinct {
            keys: Box::new([0; Distinct::SLOTS]),
            gens: Box::new([0; Distinct::SLOTS]),
            generation: 0,
        }
    }
}

impl Distinct {
    const SLOTS: usize = 1024;

    /// Appends the distinct point ids of a checked face stream
    /// (`nf, n0, ids.., n1, ids..`) to `out`, in order of first appearance.
    fn distinct_into(&mut self, stream: &[u32], out: &mut Vec<u32>) {
        let big = stream.len() > Self::SLOTS / 2;
        if !big {
            self.generation = self.generation.wrapping_add(1);
            if self.generation == 0 {
                self.gens.fill(0);
                self.generation = 1;
            }
        }
        let first = out.len();
        let mut i = 1usize;
        while i < stream.len() {
            let k = stream[i] as usize;
            let face = &stream[i + 1..i + 1 + k];
            i += 1 + k;
            if big {
                out.extend_from_slice(face);
                continue;
            }
            for &id in face {
                let mut slot = (id.wrapping_mul(0x9E37_79B1) >> 22) as usize;
                loop {
                    if self.gens[slot] != self.generation {
                        self.gens[slot] = self.generation;
                        self.keys[slot] = id;
                        out.push(id);
                        break;
                    }
                    if self.keys[slot] == id {
                        break;
                    }
                    slot = (slot + 1) & (Self::SLOTS - 1);
                }
            }
        }
        if big {
            out[first..].sort_unstable();
            let mut tail = out.split_off(first);
            tail.dedup();
            out.extend_from_slice(&tail);
        }
    }
}

/// Assembles [`Cells`] from VTK's flat arrays. `offsets` has `types.len() + 1`
/// entries indexing `conn`. Polyhedra get their face stream and the sorted
/// unique ids of their faces as connectivity.
pub(crate) fn build_cells<C: StreamValue + Sync, T: StreamValue + Sync>(
    types: &[i64],
    offsets: &[usize],
    conn: &[C],
    faces: PolyFaces<'_, T>,
    file: &str,
) -> Result<Cells, VtkReadError> {
    use rayon::prelude::*;
    const CHUNK: usize = 8192;
    let n = types.len();
    let any_poly = types.contains(&i64::from(vtk_type::POLYHEDRON));
    let range = |r: std::ops::Range<usize>| {
        build_cell_range(r, types, offsets, conn, &faces, any_poly, file)
    };
    if n <= CHUNK {
        return range(0..n);
    }
    // Chunks of cells in parallel, each with offsets from 0, then joined in
    // order (the first error in cell order wins, as in one pass).
    let parts: Vec<Result<Cells, VtkReadError>> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|k| range(k * CHUNK..((k + 1) * CHUNK).min(n)))
        .collect();
    let parts: Vec<Cells> = parts.into_iter().collect::<Result<_, _>>()?;
    // Offsets rebased (checked against u32, naming the first cell past it),
    // then every array filled by chunk in parallel.
    let over = |c: usize, what: &str| VtkReadError::Cell {
        file: file.to_string(),
        cell: c,
        msg: format!("{what} exceeds u32 offsets"),
    };
    let (mut cb, mut fb) = (0usize, 0usize);
    let mut bases = Vec::with_capacity(parts.len());
    for (k, p) in parts.iter().enumerate() {
        // The first cell of chunk `k` whose end, rebased by `base`, passes u32.
        // Offsets only grow: when the last fits, all do; else name the
        // first cell of chunk `k` whose end, rebased by `base`, passes u32.
        let check = |base: usize, offs: &[u32], what: &str| {
            let fits = |o: &u32| u32::try_from(base + *o as usize).is_ok();
            if offs.last().is_none_or(fits) {
                return Ok(());
            }
            let i = offs.iter().position(|o| !fits(o)).unwrap_or(1);
            Err(over(k * CHUNK + i.max(1) - 1, what))
        };
        check(cb, &p.offsets, "connectivity")?;
        check(fb, &p.face_offsets, "face stream")?;
        bases.push((cb, fb));
        cb += p.connectivity.len();
        fb += p.face_stream.len();
    }
    let memory = |source| VtkReadError::Memory {
        file: file.to_string(),
        source,
    };
    let mut cells = Cells {
        types: try_filled(n, 0, "the cell types").map_err(memory)?,
        offsets: try_filled(n + 1, 0, "the cell offsets").map_err(memory)?,
        connectivity: try_filled(cb, 0, "the cell connectivity").map_err(memory)?,
        face_offsets: if any_poly {
            try_filled(n + 1, 0, "the polyhedra's face offsets").map_err(memory)?
        } else {
            Vec::new()
        },
        face_stream: try_filled(fb, 0, "the polyhedra's faces").map_err(memory)?,
    };
    cells.offsets[n] = cb as u32;
    if any_poly {
        cells.face_offsets[n] = fb as u32;
    }
    let counts = |f: fn(&Cells) -> usize| parts.iter().map(f).collect::<Vec<_>>();
    let cell_counts = counts(|p| p.types.len());
    let types = split_lengths(&mut cells.types, &cell_counts);
    let offs = split_lengths(&mut cells.offsets[..n], &cell_counts);
    let foffs = if any_poly {
        split_lengths(&mut cells.face_offsets[..n], &cell_counts)
    } else {
        (0..parts.len()).map(|_| &mut [][..]).collect()
    };
    let conn_parts = split_lengths(&mut cells.connectivity, &counts(|p| p.connectivity.len()));
    let fs_parts = split_lengths(&mut cells.face_stream, &counts(|p| p.face_stream.len()));
    parts
        .par_iter()
        .zip(bases)
        .zip(types)
        .zip(offs)
        .zip(foffs)
        .zip(conn_parts)
        .zip(fs_parts)
        .for_each(|((((((p, (cb, fb)), t), o), fo), cn), fs)| {
            t.copy_from_slice(&p.types);
            for (d, &x) in o.iter_mut().zip(&p.offsets) {
                *d = (cb + x as usize) as u32;
            }
            for (d, &x) in fo.iter_mut().zip(&p.face_offsets) {
                *d = (fb + x as usize) as u32;
            }
            cn.copy_from_slice(&p.connectivity);
            fs.copy_from_slice(&p.face_stream);
        });
    Ok(cells)
}

/// [`build_cells`] for cells `range` (`any_poly`: of the whole grid), with
/// offsets counted from the range's first cell.
fn build_cell_range<C: StreamValue, T: StreamValue>(
    range: std::ops::Range<usize>,
    types: &[i64],
    offsets: &[usize],
    conn: &[C],
    faces: &PolyFaces<'_, T>,
    any_poly: bool,
    file: &str,
) -> Result<Cells, VtkReadError> {
    let n = range.len();
    let cell_err = |cell: usize, msg: String| VtkReadError::Cell {
        file: file.to_string(),
        cell,
        msg,
    };
    let mut cells = Cells {
        types: Vec::with_capacity(n),
        offsets: Vec::with_capacity(n + 1),
        connectivity: Vec::new(),
        face_offsets: Vec::new(),
        face_stream: Vec::new(),
    };
    cells.offsets.push(0);
    if any_poly {
        cells.face_offsets.reserve(n + 1);
        cells.face_offsets.push(0);
    }
    let mut seen = Distinct::default();
    for c in range {
        let t = types[c];
        let t8 = u8::try_from(t)
            .map_err(|_| cell_err(c, format!("cell type {t} is not a VTK cell type id")))?;
        let (a, b) = (
            offsets.get(c).copied().unwrap_or(0),
            offsets.get(c + 1).copied().unwrap_or(0),
        );
        let ids = conn
            .get(a..b)
            .ok_or_else(|| cell_err(c, format!("connectivity range {a}..{b} out of bounds")))?;
        if t8 == vtk_type::POLYHEDRON {
            let fs = cells.face_stream.len();
            match faces {
                PolyFaces::InConnectivity => push_face_stream(ids, &mut cells.face_stream),
                PolyFaces::Streams { stream, ranges } => {
                    let Some((fa, fb)) = ranges.get(c).copied().flatten() else {
                        return Err(cell_err(c, "polyhedron without faces".into()));
                    };
                    let stream = stream.get(fa..fb).ok_or_else(|| {
                        cell_err(c, format!("face range {fa}..{fb} out of bounds"))
                    })?;
                    push_face_stream(stream, &mut cells.face_stream)
                }
            }
            .map_err(|m| cell_err(c, m))?;
            let first = cells.connectivity.len();
            seen.distinct_into(&cells.face_stream[fs..], &mut cells.connectivity);
            cells.connectivity[first..].sort_unstable();
        } else {
            for &v in ids {
                cells
                    .connectivity
                    .push(point_id(v.to_i64()).map_err(|m| cell_err(c, m))?);
            }
        }
        let end = u32::try_from(cells.connectivity.len())
            .map_err(|_| cell_err(c, "connectivity exceeds u32 offsets".into()))?;
        cells.offsets.push(end);
        cells.types.push(t8);
        if any_poly {
            let fend = u32::try_from(cells.face_stream.len())
                .map_err(|_| cell_err(c, "face stream exceeds u32 offsets".into()))?;
            cells.face_offsets.push(fend);
        }
    }
    Ok(cells)
}

/// Groups a flat coordinate vector into points (`flat.len()` must be a
/// multiple of 3) in `file`; the points are allocated first, fallibly.
pub(crate) fn to_points(flat: &[f64], file: &str) -> Result<Vec<[f64; 3]>, VtkReadError> {
    use rayon::prelude::*;
    let mut out = try_vec(flat.len() / 3, "the points").map_err(|source| VtkReadError::Memory {
        file: file.to_string(),
        source,
    })?;
    flat.par_chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect_into_vec(&mut out);
    Ok(out)
}

/// Number of cells of a structured grid with point dims `d`, or `None` on overflow.
pub(crate) fn structured_cells(d: [usize; 3]) -> Option<usize> {
    d[0].saturating_sub(1)
        .checked_mul(d[1].saturating_sub(1))?
        .checked_mul(d[2].saturating_sub(1))
}

/// Final checks: structured dims are checked for overflow here (so that
/// [`Grid::validate`] cannot overflow), then the grid is validated, and
/// hexahedra whose corners coincide (pinched cells, points the file
/// repeats) are typed as the corner-point conversion types them
/// ([`crate::cornerpoint::collapse_hexahedra`]).
pub(crate) fn finish(mut grid: Grid, file: &str) -> Result<Grid, VtkReadError> {
    if let Topology::Structured { dims } = &grid.topology {
        let expected = dims[0]
            .checked_mul(dims[1])
            .and_then(|v| v.checked_mul(dims[2]));
        if expected != Some(grid.points.len()) || structured_cells(*dims).is_none() {
            return Err(VtkReadError::Unsupported {
                file: file.to_string(),
                what: format!(
                    "structured dims {dims:?} do not match the {} points read",
                    grid.points.len()
                ),
            });
        }
    }
    grid.validate().map_err(|source| VtkReadError::Invalid {
        file: file.to_string(),
        source,
    })?;
    crate::cornerpoint::collapse_hexahedra(&mut grid);
    Ok(grid)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The linear-time distinct ids of a face stream equal sort + dedup,
    /// for small streams (the table) and large ones (the sort fallback),
    /// with ids that collide in the table.
    #[test]
    fn distinct_ids_match_sort_and_dedup() {
        let mut seen = Distinct::default();
        let mut state = 7u64;
        let mut next = |m: u64| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) % m
        };
        for round in 0..300 {
            let (nf, span) = if round % 10 == 0 {
                (120, 5000)
            } else {
                (1 + next(20), 1 + next(60))
            };
            let mut stream = vec![nf as u32];
            let mut want = Vec::new();
            for _ in 0..nf {
                let k = 3 + next(6) as u32;
                stream.push(k);
                for _ in 0..k {
                    // Multiples of 1024 land on the same table slot.
                    let id = (next(span) * if round % 3 == 0 { 1024 } else { 1 }) as u32;
                    stream.push(id);
                    want.push(id);
                }
            }
            want.sort_unstable();
            want.dedup();
            let mut got = vec![99];
            seen.distinct_into(&stream, &mut got);
            assert_eq!(got[0], 99, "round {round}: prefix kept");
            let mut tail = got.split_off(1);
            let n = tail.len();
            tail.sort_unstable();
            tail.dedup();
            assert_eq!(tail.len(), n, "round {round}: no repeats");
            assert_eq!(tail, want, "round {round}");
        }
    }

    /// Narrowing to u32 ids agrees with the i64 decode for every integer
    /// type and byte order, and refuses (None) any array holding a value
    /// outside `0..u32::MAX`.
    #[test]
    fn u32_ids_match_the_i64_decode() {
        let vals: [i64; 5] = [0, 1, 7, 65_535, 4_294_967_294];
        for big in [false, true] {
            for ty in [Scalar::I32, Scalar::U32, Scalar::I64, Scalar::U64] {
                let size = ty.size();
                let enc = |v: i64| -> Vec<u8> {
                    let b = v.to_le_bytes();
                    let mut x = b[..size].to_vec();
                    if big {
                        x.reverse();
                    }
                    x
                };
                let fits = |v: i64| match ty {
                    Scalar::I32 => i32::try_from(v).is_ok(),
                    Scalar::U32 => u32::try_from(v).is_ok(),
                    _ => true,
                };
                let good: Vec<u8> = vals
                    .iter()
                    .filter(|&&v| fits(v))
                    .flat_map(|&v| enc(v))
                    .collect();
                let want: Vec<u32> = decode_i64(&good, ty, big, 0)
                    .unwrap()
                    .iter()
                    .map(|&v| v as u32)
                    .collect();
                assert_eq!(
                    decode_u32_ids(&good, ty, big, "ids").unwrap(),
                    Some(want),
                    "{ty:?} big {big}"
                );
                for bad in [-1i64, 4_294_967_295, 1 << 40] {
                    if !fits(bad) || (bad < 0 && matches!(ty, Scalar::U32 | Scalar::U64)) {
                        continue;
                    }
                    let mut b = good.clone();
                    b.extend(enc(bad));
                    assert_eq!(
                        decode_u32_ids(&b, ty, big, "ids").unwrap(),
                        None,
                        "{ty:?} {bad}"
                    );
                }
            }
        }
    }

    /// Cells built in parallel chunks equal one sequential pass, and the
    /// first bad cell in cell order is the one named.
    #[test]
    fn chunked_cells_equal_one_pass() {
        let n = 20_000usize;
        let (mut types, mut offsets, mut conn) = (Vec::new(), vec![0usize], Vec::new());
        let (mut stream, mut ranges) = (Vec::<i64>::new(), Vec::new());
        for c in 0..n as i64 {
            let v = [c, c + 1, c + 2, c + 3];
            conn.extend_from_slice(&v);
            offsets.push(conn.len());
            if c % 3 == 0 {
                types.push(i64::from(vtk_type::POLYHEDRON));
                let a = stream.len();
                stream.push(4);
                for f in [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]] {
                    stream.push(3);
                    stream.extend(f.iter().map(|&i| v[i]));
                }
                ranges.push(Some((a, stream.len())));
            } else {
                types.push(i64::from(vtk_type::TETRA));
                ranges.push(None);
            }
        }
        fn faces<'a>(
            stream: &'a [i64],
            ranges: &'a [Option<(usize, usize)>],
        ) -> PolyFaces<'a, i64> {
            PolyFaces::Streams { stream, ranges }
        }
        let whole = build_cells(&types, &offsets, &conn, faces(&stream, &ranges), "f").unwrap();
        let one = build_cell_range(
            0..n,
            &types,
            &offsets,
            &conn,
            &faces(&stream, &ranges),
            true,
            "f",
        )
        .unwrap();
        assert_eq!(whole, one);
        assert_eq!(whole.len(), n);
        // Two bad cells in different chunks: the earlier one is named.
        for bad in [17_000usize, 9_001] {
            stream[ranges[bad - bad % 3].unwrap().0 + 2] = -5;
        }
        let e = build_cells(&types, &offsets, &conn, faces(&stream, &ranges), "f").unwrap_err();
        assert!(e.to_string().contains("cell 9000"), "{e}");
    }

    /// The whole-stream fast path accepts what the checked path accepts
    /// and reports the same errors.
    #[test]
    fn face_stream_fast_path_matches_checked_path() {
        for s in [
            vec![2i64, 3, 0, 1, 2, 3, 2, 1, 3],
            vec![2, 3, 0, 1, 2, 3, 2, 1],
            vec![2, 3, 0, 1, 2, 3, 2, 1, 3, 9],
            vec![1, 3, 0, -1, 2],
            vec![1, 3, 0, 1, 4_294_967_295],
            vec![3, 3, 0, 1, 2],
            vec![],
            vec![1, -3, 0, 1, 2],
        ] {
            let (mut a, mut b) = (vec![5u32], vec![5u32]);
            let fast = push_face_stream(&s, &mut a);
            let slow = push_face_stream_checked(&s, &mut b);
            assert_eq!(fast, slow, "{s:?}");
            if slow.is_ok() {
                assert_eq!(a, b, "{s:?}");
            } else {
                assert_eq!(a, vec![5], "{s:?}: nothing appended on error");
            }
        }
    }

    #[test]
    fn ints() {
        assert_eq!(parse_i64(b"-42"), Some(-42));
        assert_eq!(parse_i64(b"4.0"), Some(4));
        assert_eq!(parse_i64(b"4.5"), None);
        assert_eq!(parse_i64(b"99999999999999999999"), None);
        assert_eq!(parse_i64(b"-"), None);
    }

    #[test]
    fn names() {
        assert_eq!(decode_name(b"my%20array"), "my array");
        assert_eq!(decode_name(b"50%"), "50%");
        assert_eq!(decode_name(b"%2"), "%2");
    }
}
