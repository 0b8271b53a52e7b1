//! The outer surface of a grid as triangles (no wgpu): the cell faces that
//! no second cell shares. The pre-integrated volume pass draws it to find
//! where each ray enters and leaves the grid (nearest and farthest hit).
//!
//! * Structured grids with every cell shown: the six faces of the IJK point
//!   lattice (or of the clipped IJK box), two triangles per quad.
//! * Any other grid (zoo, polyhedral, corner-point, structured with hidden
//!   cells): every face of every shown cell is matched by its sorted vertex
//!   ids in one hash pass (O(cells)); the faces left unmatched are
//!   triangulated, a quad or polygon as a fan around its vertex mean (the
//!   split the crate measures cell volumes with). Typed cells use VTK's
//!   outward face tables; a polyhedron's faces are first turned outward
//!   (files list them either way round).
//!
//! * Corner-point graphs ([`graph_boundary_triangles`]): the same matching
//!   over the graph's own live cells (hexahedra, collapsed cells and the
//!   convex pieces of split cells, with their meta-cells' outward faces),
//!   each corner carrying its vertex's lattice node `(i, j, k)`.
//!
//! Corner-point faults: cells across a fault share no vertex, so a fault
//! face is never matched and is kept **whole**, also where the other side
//! covers it. The surface then holds the true outer surface plus pieces
//! inside the grid. For a ray from outside, the nearest and farthest hits
//! are unchanged: every point of such a piece lies in the grid, so the ray
//! has crossed the true surface before (or at) it and crosses it again
//! after. The pre-integrated pass only keeps the nearest (depth `Less`) and
//! farthest (`Greater`) hit, with no face culling, so the extra pieces
//! change nothing there. The surface is closed as a chain (each cell's
//! boundary is closed and matched faces leave in pairs), not a manifold.

mod faces;
#[cfg(test)]
mod tests;

use rayon::prelude::*;

use crate::cellgraph::CellGraph;
use crate::grid::{Grid, Topology, hex_corner_offsets};
use crate::metacell::MAX_META_VERTICES;
use faces::OpenFaces;

/// Cells per run matched on one thread.
const RUN: usize = 1 << 16;

/// A triangulated surface: world positions (f64) and triangles of indices
/// into them, oriented outward from the cell each face came from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Surface {
    /// Positions: the grid's points that the surface uses, then the added
    /// face centres.
    pub points: Vec<[f64; 3]>,
    /// Triangles (counter-clockwise seen from outside their cell).
    pub triangles: Vec<[u32; 3]>,
    /// Each point's index coordinate `(i, j, k)` on structured grids (the
    /// added face centres: their corners' mean); empty on other grids.
    pub ijk: Vec<[f64; 3]>,
}

/// Cell index ranges `lo..hi` along I, J, K of a structured grid.
pub type IjkBox = [[usize; 2]; 3];

/// The outer surface of `grid`'s shown cells (see the module notes).
pub fn outer_surface(grid: &Grid) -> Surface {
    outer_surface_in(grid, None)
}

/// [`outer_surface`] of the cells inside `clip` only (structured grids;
/// ignored for unstructured ones). The box is cut to the grid.
pub fn outer_surface_in(grid: &Grid, clip: Option<IjkBox>) -> Surface {
    let hidden = grid.hidden_cells().filter(|h| h.iter().any(|&x| x));
    let mut open = OpenFaces::default();
    match &grid.topology {
        Topology::Structured { dims } => {
            let full = [0, 1, 2].map(|a| [0, dims[a].saturating_sub(1)]);
            let b = clip.map_or(full, |c| {
                [0, 1, 2].map(|a| [c[a][0].min(full[a][1]), c[a][1].min(full[a][1])])
            });
            if b.iter().any(|r| r[0] >= r[1]) {
                return Surface::default();
            }
            match hidden {
                None => return lattice_surface(grid, *dims, b),
                Some(h) => toggle_lattice_cells(*dims, b, &h, &mut open),
            }
        }
        Topology::Unstructured(cells) => {
            // Runs of cells matched in parallel; their open faces then in
            // run order (the same surface, in the same order, as one pass).
            let runs: Vec<OpenFaces> = (0..cells.len().div_ceil(RUN))
                .into_par_iter()
                .map(|r| {
                    let mut run = OpenFaces::default();
                    for c in r * RUN..((r + 1) * RUN).min(cells.len()) {
                        if hidden.as_ref().is_none_or(|h| h.get(c) != Some(&true)) {
                            faces::toggle_cell_faces(cells, &grid.points, c, &mut run);
                        }
                    }
                    run
                })
                .collect();
            for run in &runs {
                for f in run.loops() {
                    open.toggle(f);
                }
            }
        }
    }
    compact(grid, &open.loops())
}

/// The outer surface as a triangle soup (three corners per triangle) in the
/// local frame: each corner its position relative to [`Grid::origin`] (z
/// not exaggerated), then its index coordinate `(i, j, k)` (zero on
/// unstructured grids). `None` when the grid has no cell to bound.
pub fn boundary_triangles(grid: &Grid) -> Option<Vec<[f32; 6]>> {
    boundary_triangles_in(grid, None)
}

/// [`boundary_triangles`] of the cells inside the IJK box `clip`.
pub fn boundary_triangles_in(grid: &Grid, clip: Option<IjkBox>) -> Option<Vec<[f32; 6]>> {
    let s = outer_surface_in(grid, clip);
    if s.triangles.is_empty() {
        return None;
    }
    let o = grid.origin();
    let corner = |v: u32| {
        let p = s.points[v as usize];
        let n = s.ijk.get(v as usize).copied().unwrap_or_default();
        let x = [0, 1, 2].map(|a| (p[a] - o[a]) as f32);
        [x[0], x[1], x[2], n[0] as f32, n[1] as f32, n[2] as f32]
    };
    Some(s.triangles.iter().flatten().map(|&v| corner(v)).collect())
}

/// The outer surface of a cell graph's live cells as a triangle soup in the
/// graph's rebased frame: each corner its position, then `ijk` of its
/// vertex (a fan centre: the mean of its face's). Every live cell counts,
/// whatever its meta-cell (hexahedra, collapsed cells, convex pieces), so
/// the surface is closed as a chain: a collapsed cell on the outside
/// leaves no hole through which a ray would leave unseen. Faces across a
/// fault (no shared vertex) and a hexahedron's face against the triangles
/// of a split neighbour stay, inside the grid (see the module notes).
pub fn graph_boundary_triangles<G: CellGraph>(g: &G, ijk: &[[f32; 4]]) -> Vec<[f32; 6]> {
    let mut open = OpenFaces::default();
    let mut ids = [0u32; MAX_META_VERTICES];
    for slot in 0..g.slot_count() as u32 {
        if g.is_live(slot) {
            let (m, n) = g.cell(slot, &mut ids);
            faces::toggle_local(&g.catalog().get(m).faces, &ids[..n], &mut open);
        }
    }
    let loops = open.loops();
    let (pos, node) = (g.positions(), |v: u32| ijk[v as usize]);
    let mut used = Vec::new();
    let mut map = vec![u32::MAX; pos.len()];
    let local: Vec<Vec<u32>> = loops
        .iter()
        .map(|f| {
            f.iter()
                .map(|&v| {
                    if map[v as usize] == u32::MAX {
                        map[v as usize] = used.len() as u32;
                        used.push(v);
                    }
                    map[v as usize]
                })
                .collect()
        })
        .collect();
    let refs: Vec<&[u32]> = local.iter().map(|f| f.as_slice()).collect();
    let mut points: Vec<[f64; 3]> = used
        .iter()
        .map(|&v| pos[v as usize].map(f64::from))
        .collect();
    let mut nodes: Vec<[f64; 3]> = used
        .iter()
        .map(|&v| {
            let n = node(v);
            [n[0], n[1], n[2]].map(f64::from)
        })
        .collect();
    let triangles = faces::triangulate(&refs, &mut points);
    faces::triangulate(&refs, &mut nodes);
    triangles
        .iter()
        .flatten()
        .map(|&v| {
            let (p, n) = (points[v as usize], nodes[v as usize]);
            [p[0], p[1], p[2], n[0], n[1], n[2]].map(|x| x as f32)
        })
        .collect()
}

/// The index coordinates of the grid points `used` (structured grids;
/// empty on others).
fn ijk_of(grid: &Grid, used: &[u32]) -> Vec<[f64; 3]> {
    let Topology::Structured { dims } = grid.topology else {
        return Vec::new();
    };
    let [npi, npj, _] = dims;
    let at = |v: u32| {
        let v = v as usize;
        [v % npi, (v / npi) % npj, v / (npi * npj)].map(|x| x as f64)
    };
    used.iter().map(|&v| at(v)).collect()
}

/// The six faces of the IJK cell box `b` of a lattice, two triangles per
/// quad, outward.
fn lattice_surface(grid: &Grid, dims: [usize; 3], b: IjkBox) -> Surface {
    let id = |ijk: [usize; 3]| (ijk[0] + dims[0] * (ijk[1] + dims[1] * ijk[2])) as u32;
    let mut loops: Vec<[u32; 4]> = Vec::new();
    // Each outer face: fix axis `a` at the box's low or high side; walk the other two.
    for a in 0..3 {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for (side, high) in [(b[a][0], false), (b[a][1], true)] {
            for i in b[u][0]..b[u][1] {
                for j in b[v][0]..b[v][1] {
                    let p = |du: usize, dv: usize| {
                        let mut ijk = [0; 3];
                        ijk[a] = side;
                        ijk[u] = i + du;
                        ijk[v] = j + dv;
                        id(ijk)
                    };
                    // (u, v, a) is right-handed: this loop faces +a.
                    let q = [p(0, 0), p(1, 0), p(1, 1), p(0, 1)];
                    loops.push(if high { q } else { [q[0], q[3], q[2], q[1]] });
                }
            }
        }
    }
    let mut map = IdMap::new(grid.points.len());
    let mut points = Vec::new();
    let mut triangles = Vec::with_capacity(2 * loops.len());
    for q in loops {
        let q = q.map(|v| map.get(v, &grid.points, &mut points));
        triangles.push([q[0], q[1], q[2]]);
        triangles.push([q[0], q[2], q[3]]);
    }
    let ijk = ijk_of(grid, &map.used);
    Surface {
        points,
        triangles,
        ijk,
    }
}

/// Adds the hexahedra of the IJK box `b` that are not hidden.
fn toggle_lattice_cells(dims: [usize; 3], b: IjkBox, hidden: &[bool], open: &mut OpenFaces) {
    let [npi, npj, _] = dims;
    let off = hex_corner_offsets(npi, npi * npj);
    let (nci, ncj) = (npi - 1, npj - 1);
    for k in b[2][0]..b[2][1] {
        for j in b[1][0]..b[1][1] {
            for i in b[0][0]..b[0][1] {
                if hidden.get(i + nci * (j + ncj * k)) == Some(&true) {
                    continue;
                }
                let first = i + npi * (j + npj * k);
                let ids = off.map(|o| (first + o) as u32);
                faces::toggle_local(&crate::metacell::HEXAHEDRON_FACES, &ids, open);
            }
        }
    }
}

/// The surface of face loops over the grid's points, keeping only the
/// points it uses.
fn compact(grid: &Grid, loops: &[&[u32]]) -> Surface {
    let mut map = IdMap::new(grid.points.len());
    let mut points = Vec::new();
    let local: Vec<Vec<u32>> = loops
        .iter()
        .map(|f| {
            f.iter()
                .map(|&v| map.get(v, &grid.points, &mut points))
                .collect()
        })
        .collect();
    let refs: Vec<&[u32]> = local.iter().map(|f| f.as_slice()).collect();
    let triangles = faces::triangulate(&refs, &mut points);
    let mut ijk = ijk_of(grid, &map.used);
    if !ijk.is_empty() {
        // The same fans over the index coordinates add the centres' (i, j, k).
        faces::triangulate(&refs, &mut ijk);
    }
    Surface {
        points,
        triangles,
        ijk,
    }
}

/// Grid point id → surface point id, assigned on first use; `used` lists
/// the grid ids in surface order.
struct IdMap {
    ids: Vec<u32>,
    used: Vec<u32>,
}

impl IdMap {
    fn new(n: usize) -> Self {
        IdMap {
            ids: vec![u32::MAX; n],
            used: Vec::new(),
        }
    }

    fn get(&mut self, v: u32, grid: &[[f64; 3]], out: &mut Vec<[f64; 3]>) -> u32 {
        let slot = &mut self.ids[v as usize];
        if *slot == u32::MAX {
            *slot = out.len() as u32;
            out.push(grid[v as usize]);
            self.used.push(v);
        }
        *slot
    }
}
