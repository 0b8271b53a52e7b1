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
use crate::grid::{Grid, Topology};
use cgraph::CGraph;
use ciel::Ciel;
use convex_split::{Split, SplitMap, split_non_convex_cells, split_non_convex_pieces};
use cpgraph::{CpGraph, IjkLayout};
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
        let g = CpGraph::build(grid, hidden.as_deref(), split, layout)?;
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
                return Ok(Structure::SCGraph(SCGraph::build(grid, hidden.as_deref())?));
            }
            StructureChoice::Ciel => {}
            StructureChoice::CpGraph => unreachable!("handled above"),
            _ => {
                // CGraph: split non-convex polyhedra first, then build once.
                let (split_grid, map, h) = split_for_build(grid, hidden)?;
                let g = split_grid.as_ref().unwrap_or(grid);
                return match CGraph::build(g, h.as_deref()) {
                    Ok(inner) => Ok(Structure::CGraph(Split { inner, map })),
                    // A cell the catalog cannot take (large or odd polyhedra): CIEL.
                    Err(StructureError::UnsupportedCell { .. })
                        if choice != StructureChoice::CGraph =>
                    {
                        Ok(Structure::Ciel(Split {
                            inner: ciel(g, h.as_deref())?,
                            map,
                        }))
                    }
                    Err(e) => Err(e.into()),
                };
            }
        }
        // CIEL counts non-convex cells while building: split and rebuild only
        // when there are some (no extra pass for convex grids).
        let c = ciel(grid, hidden.as_deref())?;
        if c.counts.non_convex == 0 {
            return Ok(Structure::Ciel(c.into()));
        }
        let Some(split) = split_non_convex_cells(grid, hidden.as_deref())? else {
            return Ok(Structure::Ciel(c.into()));
        };
        let h = split.map.hidden_cells(hidden.as_deref());
        Ok(Structure::Ciel(Split {
            inner: ciel(&split.grid, h.as_deref())?,
            map: Some(split.map),
        }))
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
/// over the polyhedra, nothing when there are none): the split grid (None:
/// use `grid`), its map and the hidden cells to build with. The split grid
/// carries no properties (the structures read points and cells only); its
/// hidden cells come from the map.
type SplitForBuild = (Option<Grid>, Option<SplitMap>, Option<Vec<bool>>);
fn split_for_build(grid: &Grid, hidden: Option<Vec<bool>>) -> Result<SplitForBuild, BuildError> {
    Ok(match split_non_convex_cells(grid, hidden.as_deref())? {
        Some(sp) => {
            let h = sp.map.hidden_cells(hidden.as_deref());
            (Some(sp.grid), Some(sp.map), h)
        }
        None => (None, None, hidden),
    })
}
