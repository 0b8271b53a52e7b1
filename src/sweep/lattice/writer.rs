//! [`HexWriter`]: appends a batch of lattice cells' polygons to a
//! [`LevelMesh`] without a capacity check per element.

use crate::extract::{LevelMesh, norm2_of};

/// Appends to a [`LevelMesh`] without a capacity check per element: made
/// for a batch of at most `cells` cells, for which it reserves room (at
/// most [`HexWriter::PER_CELL`] new vertices, corners and polygons per
/// cell: a hexahedron's); the vectors' lengths and the sums are set when it
/// is dropped. The lattice emitter writes through it: on warped 128³ (200
/// levels) the `Vec` pushes of the emission took about a third of its
/// instructions. Keep it a local that is only used by inlined code, so that
/// its counters stay in registers.
pub(crate) struct HexWriter<'m> {
    mesh: &'m mut LevelMesh,
    positions: *mut [f32; 3],
    values: *mut f32,
    keys: *mut u64,
    indices: *mut u32,
    offsets: *mut u32,
    cells: *mut u32,
    /// Vertices written (the lengths of positions, values and keys).
    nv: usize,
    /// Corners written (the length of indices).
    ni: usize,
    /// Polygons written (the length of cells; offsets holds one more).
    np: usize,
    /// Cells that may still begin.
    room: usize,
    area: f64,
    triangles: usize,
    cut_cells: u32,
}

impl<'m> HexWriter<'m> {
    /// Most vertices, corners or polygons one cell may add.
    pub(crate) const PER_CELL: usize = 12;

    /// A writer appending at most `cells` cells to `mesh`.
    #[inline(always)]
    pub(crate) fn new(mesh: &'m mut LevelMesh, cells: usize) -> Self {
        debug_assert_eq!(mesh.offsets.len(), mesh.cells.len() + 1);
        reserve_cells(mesh, cells);
        HexWriter {
            positions: mesh.positions.as_mut_ptr(),
            values: mesh.values.as_mut_ptr(),
            keys: mesh.edge_keys.as_mut_ptr(),
            indices: mesh.indices.as_mut_ptr(),
            offsets: mesh.offsets.as_mut_ptr(),
            cells: mesh.cells.as_mut_ptr(),
            nv: mesh.positions.len(),
            ni: mesh.indices.len(),
            np: mesh.cells.len(),
            room: cells,
            area: mesh.area,
            triangles: mesh.triangle_sum,
            cut_cells: mesh.cut_cells,
            mesh,
        }
    }

    /// Starts a cut cell (one of the `cells` the writer was made for).
    #[inline(always)]
    pub(crate) fn begin_cell(&mut self) {
        assert!(self.room > 0, "more cells than the writer was made for");
        self.room -= 1;
        self.cut_cells += 1;
    }

    /// Appends a vertex welded by the caller (grid edge `key`); returns its
    /// index. At most [`HexWriter::PER_CELL`] per [`HexWriter::begin_cell`].
    #[inline(always)]
    pub(crate) fn vertex(&mut self, key: u64, p: [f32; 3], value: f32) -> u32 {
        let vi = self.nv;
        // SAFETY: `begin_cell` left room for PER_CELL vertices of this cell.
        unsafe {
            self.positions.add(vi).write(p);
            self.values.add(vi).write(value);
            self.keys.add(vi).write(key);
        }
        self.nv = vi + 1;
        vi as u32
    }

    /// Welds grid edge `key` by the mesh's hash map: its vertex, and
    /// whether it is new (then append it with [`HexWriter::vertex`] before
    /// any other vertex: the map already holds the index it will get).
    #[inline(always)]
    pub(crate) fn hashed(&mut self, key: u64) -> (u32, bool) {
        // SAFETY: every key below `nv` was written (the mesh's own, then
        // this writer's).
        let keys = unsafe { std::slice::from_raw_parts(self.keys, self.nv) };
        let map = self.mesh.edge_map();
        map.reserve(1, keys);
        map.get_or_insert(key, self.nv as u32, keys)
    }

    /// Vertices in the mesh so far.
    #[inline(always)]
    pub(crate) fn vertices(&self) -> usize {
        self.nv
    }

    /// The grid edge of vertex `v`, one of the mesh's vertices so far.
    #[inline(always)]
    pub(crate) fn key(&self, v: u32) -> u64 {
        assert!((v as usize) < self.nv, "vertex {v} not written yet");
        // SAFETY: every vertex below `nv` was written (the mesh's own, then
        // this writer's).
        unsafe { self.keys.add(v as usize).read() }
    }

    /// Appends the polygon of source cell `slot` with the `m` corners
    /// `corner(0..m)` (vertices already written), adding its area as
    /// [`LevelMesh::end_polygon`] does. At most [`HexWriter::PER_CELL`]
    /// corners and polygons per [`HexWriter::begin_cell`].
    #[inline(always)]
    pub(crate) fn polygon(&mut self, m: usize, corner: impl Fn(usize) -> u32, slot: u32) {
        debug_assert!((3..=Self::PER_CELL).contains(&m));
        let start = self.ni;
        // SAFETY: room for PER_CELL corners and PER_CELL polygons of this cell
        // (`begin_cell`), and one corner more in all (`reserve_cells`) for
        // a triangle's fourth; every corner is a vertex index below `nv`,
        // so its position was written.
        unsafe {
            let pos = self.positions;
            let at = |i: usize| (*pos.add(*self.indices.add(start + i) as usize)).map(f64::from);
            let n2 = if m <= 4 {
                // Triangles and quadrilaterals without a branch on which:
                // a triangle's fourth corner is its first, and the
                // quadrilateral's diagonal product of `norm2_of` with
                // p3 = p0 is the triangle's fan product, bit for bit
                // (p0 − p1 is exactly −(p1 − p0), and adding it to 0 only
                // changes the sign of a zero, which the squares drop).
                let last = if m == 4 { 3 } else { 0 };
                for i in 0..3 {
                    self.indices.add(start + i).write(corner(i));
                }
                self.indices.add(start + 3).write(corner(last));
                norm2_of(4, at)
            } else {
                for i in 0..m {
                    self.indices.add(start + i).write(corner(i));
                }
                norm2_of(m, at)
            };
            self.area += 0.5 * n2.sqrt();
            self.ni = start + m;
            self.offsets.add(self.np + 1).write(self.ni as u32);
            self.cells.add(self.np).write(slot);
        }
        self.np += 1;
        self.triangles += m - 2;
    }
}

impl Drop for HexWriter<'_> {
    #[inline(always)]
    fn drop(&mut self) {
        // SAFETY: every element below these lengths was written (vertices,
        // corners and polygons are appended in order) within the room
        // reserved by `new`: at most PER_CELL of each per begun cell.
        unsafe {
            self.mesh.positions.set_len(self.nv);
            self.mesh.values.set_len(self.nv);
            self.mesh.edge_keys.set_len(self.nv);
            self.mesh.indices.set_len(self.ni);
            self.mesh.offsets.set_len(self.np + 1);
            self.mesh.cells.set_len(self.np);
        }
        self.mesh.area = self.area;
        self.mesh.triangle_sum = self.triangles;
        self.mesh.cut_cells = self.cut_cells;
    }
}

/// Makes room in `mesh` for `cells` more cells of at most
/// [`HexWriter::PER_CELL`] vertices, corners and polygons each.
#[inline(never)]
fn reserve_cells(mesh: &mut LevelMesh, cells: usize) {
    let extra = cells * HexWriter::PER_CELL;
    mesh.positions.reserve(extra);
    mesh.values.reserve(extra);
    mesh.edge_keys.reserve(extra);
    // One more corner: a triangle writes a fourth (see `polygon`).
    mesh.indices.reserve(extra + 1);
    mesh.offsets.reserve(extra);
    mesh.cells.reserve(extra);
}
