//! The sweep structures and their choice: S-CGraph (implicit IJK),
//! CGraph (cell graph over the meta-cell catalog), CIEL (half-edges, any
//! convex polyhedra), the convex split of non-convex polyhedra below CGraph
//! and CIEL, and what they share (build errors, cell classes, a bit set).

pub mod cell_check;
pub mod cgraph;
pub mod ciel;
pub mod common;
pub mod convex_split;
pub mod cpgraph;
mod hex_lanes;
pub mod polyhedron;
mod resolve;
pub mod scgraph;

pub use common::{
    BitSet, CELL_CLASS_COUNT, CELL_CLASS_NAMES, CellClass, StructureError, classify_cell,
    is_sweepable, quad_is_bow_tie,
};

use crate::cellgraph::CellGraph;
use crate::grid::IjkLayout;
use crate::grid::{Grid, Topology};
use cgraph::CGraph;
use ciel::Ciel;
use convex_split::{
    Split, SplitMap, split_non_convex_and_twisted_cells, split_non_convex_and_twisted_pieces,
    split_non_convex_cells, split_non_convex_pieces,
};
use cpgraph::CpGraph;
use scgraph::SCGraph;

/// Errors building a structure; every message names the cell or the
/// reason.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// Invalid grid.
    #[error(transparent)]
    Grid(#[from] crate::grid::GridError),
    /// The structure refuses a cell or the grid.
    #[error(transparent)]
    Structure(#[from] StructureError),
    /// A non-convex cell that cannot be split into convex pieces.
    #[error(transparent)]
    Split(#[from] convex_split::SplitError),
    /// The choice does not fit this grid.
    #[error("{0}")]
    Unsupported(String),
}

/// Which structure to build (`--structure`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StructureChoice {
    /// S-CGraph for structured input, CGraph when every cell fits the
    /// meta-cell catalog, CIEL otherwise.
    Auto,
    /// The zoo-grid cellular graph.
    CGraph,
    /// The structured cellular graph.
    SCGraph,
    /// The brute-force reference (on the auto structure's cells).
    BruteForce,
    /// CIEL, the half-edge structure for arbitrary polyhedra.
    Ciel,
    /// The corner-point graph (needs the grid's IJK layout).
    CpGraph,
}

/// A built sweep structure. CGraph and CIEL are built on the grid with its
/// non-convex polyhedra split into convex pieces ([`crate::structures::convex_split`]);
/// they report input cell ids.
pub enum Structure {
    /// S-CGraph.
    SCGraph(SCGraph),
    /// CGraph.
    CGraph(Split<CGraph>),
    /// CIEL.
    Ciel(Split<Ciel>),
    /// The corner-point graph (holds its own split).
    CpGraph(Box<CpGraph>),
}

impl Structure {
    /// Builds the chosen structure (brute force uses the auto structure).
    pub fn build(grid: &Grid, choice: StructureChoice) -> Result<Self, BuildError> {
        Self::build_with(grid, choice, None)
    }

    /// The corner-point graph of `grid` (cells from the IJK box `layout`),
    /// calling `stage` after each step of the build with its name:
    /// `"validate"`, `"split"` (the non-convex cells' convex pieces),
    /// `"graph"`.
    pub fn build_cpgraph(
        grid: &Grid,
        layout: &IjkLayout,
        stage: &mut dyn FnMut(&'static str),
    ) -> Result<Self, BuildError> {
        grid.validate()?;
        stage("validate");
        // The pieces only: the graph reads the other cells from `grid`.
        let hidden = grid.hidden_cells();
        let split = split_non_convex_pieces(grid, hidden.as_deref())?;
        stage("split");
        let mut g = CpGraph::build(grid, hidden.as_deref(), split, layout)?;
        if g.class_counts[CellClass::SelfIntersecting as usize] > 0 {
            // Twisted cells: cut them too and build again (no extra pass
            // for grids without any).
            let split = split_non_convex_and_twisted_pieces(grid, hidden.as_deref())?;
            g = CpGraph::build(grid, hidden.as_deref(), split, layout)?;
        }
        stage("graph");
        Ok(Structure::CpGraph(Box::new(g)))
    }

    /// [`Structure::build`] for a grid whose cells come from an IJK box
    /// (corner-point input, `layout`): `auto` (and the brute force) then
    /// take the corner-point graph.
    pub fn build_with(
        grid: &Grid,
        choice: StructureChoice,
        layout: Option<&IjkLayout>,
    ) -> Result<Self, BuildError> {
        let cp = match (choice, layout) {
            (StructureChoice::CpGraph, None) => {
                return Err(BuildError::Unsupported(
                    "the corner-point graph needs corner-point input (GRDECL, EGRID)".into(),
                ));
            }
            (
                StructureChoice::CpGraph | StructureChoice::Auto | StructureChoice::BruteForce,
                Some(l),
            ) if !matches!(grid.topology, Topology::Structured { .. }) => Some(l),
            _ => None,
        };
        if let Some(layout) = cp {
            return Self::build_cpgraph(grid, layout, &mut |_| {});
        }
        grid.validate()?;
        let hidden = grid.hidden_cells();
        let structured = matches!(grid.topology, Topology::Structured { .. });
        let ciel = |g: &Grid, h: Option<&[bool]>| -> Result<Ciel, BuildError> {
            Ok(Ciel::build(g, h).map_err(StructureError::from)?)
        };
        match choice {
            StructureChoice::SCGraph => {
                return Ok(Structure::SCGraph(SCGraph::build(grid, hidden.as_deref())?));
            }
            StructureChoice::Auto | StructureChoice::BruteForce if structured => {
                let s = SCGraph::build(grid, hidden.as_deref())?;
                if s.class_counts[CellClass::SelfIntersecting as usize] == 0 {
                    return Ok(Structure::SCGraph(s));
                }
                // Twisted cells: the implicit lattice cannot hold their
                // pieces; the CGraph over the split hexahedra can.
                drop(s);
                return cgraph_or_ciel(grid, hidden, choice, true);
            }
            StructureChoice::Ciel => {}
            StructureChoice::CpGraph => unreachable!("handled above"),
            _ => {
                // CGraph: split non-convex polyhedra first, then build once;
                // again with the twisted cells cut when there are some.
                let s = cgraph_or_ciel(grid, hidden.clone(), choice, false)?;
                if s.twisted_left() == 0 {
                    return Ok(s);
                }
                drop(s);
                return cgraph_or_ciel(grid, hidden, choice, true);
            }
        }
        // CIEL counts non-convex cells while building: split and rebuild only
        // when there are some (no extra pass for convex grids).
        let c = ciel(grid, hidden.as_deref())?;
        let twisted = c.counts.class_counts[CellClass::SelfIntersecting as usize] > 0;
        if c.counts.non_convex == 0 && !twisted {
            return Ok(Structure::Ciel(c.into()));
        }
        let g = as_unstructured(grid, twisted);
        let split = if twisted {
            split_non_convex_and_twisted_cells(&g, hidden.as_deref())?
        } else {
            split_non_convex_cells(&g, hidden.as_deref())?
        };
        let Some(split) = split else {
            return Ok(Structure::Ciel(c.into()));
        };
        let h = split.map.hidden_cells(hidden.as_deref());
        Ok(Structure::Ciel(Split {
            inner: ciel(&split.grid, h.as_deref())?,
            map: Some(split.map),
        }))
    }

    /// Cells with a face that crosses itself that the structure classed
    /// [`CellClass::SelfIntersecting`] and does not sweep (the S-CGraph
    /// chosen explicitly keeps them so; the other structures cut them).
    pub fn twisted_left(&self) -> usize {
        let k = CellClass::SelfIntersecting as usize;
        match self {
            Structure::SCGraph(g) => g.class_counts[k],
            Structure::CGraph(g) => g.class_counts[k],
            Structure::Ciel(g) => g.counts.class_counts[k],
            Structure::CpGraph(g) => g.class_counts[k],
        }
    }

    /// What the structure does with cells that are not sliced as they are
    /// given, one sentence each (empty when there is nothing to say): twisted
    /// cells sliced through their tetrahedral decomposition, non-convex
    /// cells that cannot be split (skipped), twisted cells left unsliced.
    /// The front ends print these beside the slices.
    pub fn cell_notes(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(m) = self.split() {
            let r = &m.report;
            if r.twisted > 0 {
                out.push(format!(
                    "{} cell(s) with a face that crosses itself (a bow-tie) sliced through a \
                     tetrahedral decomposition (coned from a vertex mean, each bow-tie \
                     face cut along the diagonal from its smallest vertex id); first ids {:?}",
                    r.twisted, r.twisted_first
                ));
            }
            if r.skipped > 0 {
                out.push(format!(
                    "{} non-convex cell(s) cannot be split into convex pieces and are not \
                     sliced; first ids {:?} (first: {})",
                    r.skipped, r.skipped_first, r.skipped_reason
                ));
            }
        }
        let left = self.twisted_left();
        if left > 0 {
            out.push(format!(
                "{left} cell(s) with a face that crosses itself are not sliced by the {} \
                 (the automatic structure choice slices them through a tetrahedral decomposition)",
                self.name()
            ));
        }
        out
    }

    /// The split of non-convex polyhedra the structure was built on, if any.
    pub fn split(&self) -> Option<&SplitMap> {
        match self {
            Structure::SCGraph(_) => None,
            Structure::CGraph(g) => g.map.as_ref(),
            Structure::Ciel(g) => g.map.as_ref(),
            Structure::CpGraph(g) => g.map.as_ref(),
        }
    }

    /// Short name (`scgraph` / `cgraph`).
    pub fn name(&self) -> &'static str {
        match self {
            Structure::SCGraph(_) => "scgraph",
            Structure::CGraph(_) => "cgraph",
            Structure::Ciel(_) => "ciel",
            Structure::CpGraph(_) => "cpgraph",
        }
    }

    /// Vertex positions in the structure's f32 local frame.
    pub fn positions(&self) -> &[[f32; 3]] {
        match self {
            Structure::SCGraph(g) => g.positions(),
            Structure::CGraph(g) => g.positions(),
            Structure::CpGraph(g) => &g.positions,
            Structure::Ciel(g) => &g.positions,
        }
    }

    /// Rebasing origin.
    pub fn origin(&self) -> [f64; 3] {
        match self {
            Structure::SCGraph(s) => s.origin,
            Structure::CGraph(c) => c.origin,
            Structure::Ciel(c) => c.origin,
            Structure::CpGraph(c) => c.origin,
        }
    }

    /// Bytes per structure part.
    pub fn bytes(&self) -> Vec<(&'static str, usize)> {
        let mut b = match self {
            Structure::SCGraph(s) => s.bytes(),
            Structure::CGraph(c) => c.bytes(),
            Structure::Ciel(c) => c.bytes(),
            Structure::CpGraph(c) => c.bytes(),
        };
        if let Some(m) = self.split() {
            b.push(("split_map", m.bytes()));
        }
        b
    }

    /// Live (sweepable) input cells (a split cell counts once).
    pub fn live_cells(&self) -> usize {
        let (live, map): (&dyn Fn(u32) -> bool, _) = match self {
            Structure::SCGraph(s) => return s.live_cells(),
            Structure::CpGraph(s) => return s.live_cells(),
            Structure::CGraph(c) => (&|x| c.inner.is_live(x), &c.map),
            Structure::Ciel(c) => (&|x| c.inner.is_live(x), &c.map),
        };
        match map {
            None => match self {
                Structure::CGraph(c) => c.live_cells(),
                Structure::Ciel(c) => c.live_cells(),
                Structure::SCGraph(_) | Structure::CpGraph(_) => unreachable!(),
            },
            Some(m) => {
                let mut n = 0;
                let mut last = u32::MAX;
                for (x, &src) in m.source.iter().enumerate() {
                    if src != last && live(x as u32) {
                        n += 1;
                        last = src;
                    }
                }
                n
            }
        }
    }

    /// Slot count (stamp array length).
    pub fn slot_count(&self) -> usize {
        match self {
            Structure::SCGraph(s) => s.slot_count(),
            Structure::CGraph(c) => c.slot_count(),
            Structure::Ciel(c) => c.cell_count(),
            Structure::CpGraph(c) => c.slot_count(),
        }
    }
}

/// Splits the non-convex polyhedra of `grid` into convex pieces (one pass
/// over the polyhedra, nothing when there are none), and with `twisted` the
/// typed cells with a face that crosses itself: the split grid (None: use
/// `grid`), its map and the hidden cells to build with. The split grid
/// carries no properties (the structures read points and cells only); its
/// hidden cells come from the map.
type SplitForBuild = (Option<Grid>, Option<SplitMap>, Option<Vec<bool>>);
fn split_for_build(
    grid: &Grid,
    hidden: Option<Vec<bool>>,
    twisted: bool,
) -> Result<SplitForBuild, BuildError> {
    let split = if twisted {
        split_non_convex_and_twisted_cells(&as_unstructured(grid, true), hidden.as_deref())?
    } else {
        split_non_convex_cells(grid, hidden.as_deref())?
    };
    Ok(match split {
        Some(sp) => {
            let h = sp.map.hidden_cells(hidden.as_deref());
            (Some(sp.grid), Some(sp.map), h)
        }
        None => (None, None, hidden),
    })
}

/// The CGraph of `grid` after [`split_for_build`], or CIEL when a cell does
/// not fit the catalog (unless the CGraph was chosen).
fn cgraph_or_ciel(
    grid: &Grid,
    hidden: Option<Vec<bool>>,
    choice: StructureChoice,
    twisted: bool,
) -> Result<Structure, BuildError> {
    let (split_grid, map, h) = split_for_build(grid, hidden, twisted)?;
    let g = split_grid.as_ref().unwrap_or(grid);
    match CGraph::build(g, h.as_deref()) {
        Ok(inner) => Ok(Structure::CGraph(Split { inner, map })),
        // A cell the catalog cannot take (large or odd polyhedra): CIEL.
        Err(StructureError::UnsupportedCell { .. }) if choice != StructureChoice::CGraph => {
            Ok(Structure::Ciel(Split {
                inner: Ciel::build(g, h.as_deref()).map_err(StructureError::from)?,
                map,
            }))
        }
        Err(e) => Err(e.into()),
    }
}

/// `grid` with unstructured cells (a structured grid's hexahedra in cell
/// order, points shared, no properties) when `needed`, so that the split can
/// cut its cells; else `grid` itself.
fn as_unstructured(grid: &Grid, needed: bool) -> std::borrow::Cow<'_, Grid> {
    let Topology::Structured { dims } = grid.topology else {
        return std::borrow::Cow::Borrowed(grid);
    };
    if !needed {
        return std::borrow::Cow::Borrowed(grid);
    }
    let [npi, npj, npk] = dims;
    let slab = npi * npj;
    let off = crate::grid::hex_corner_offsets(npi, slab);
    let mut cells = crate::grid::Cells::default();
    for k in 0..npk.saturating_sub(1) {
        for j in 0..npj.saturating_sub(1) {
            for i in 0..npi.saturating_sub(1) {
                let v0 = i + j * npi + k * slab;
                cells.push(
                    crate::grid::vtk_type::HEXAHEDRON,
                    &off.map(|o| (v0 + o) as u32),
                );
            }
        }
    }
    std::borrow::Cow::Owned(Grid {
        points: grid.points.clone(),
        topology: Topology::Unstructured(cells),
        point_data: Vec::new(),
        cell_data: Vec::new(),
    })
}
