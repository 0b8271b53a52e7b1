//! The reports the CLI prints and the Python package returns: `info
//! --json` ([`info_json`]), `slice --stats` ([`stats_json`]), memory per
//! structure ([`memory_json`]), and the per-cell flattening of an output
//! mesh ([`flatten_by_cell`]). No I/O: callers pass their own timings.

use serde_json::{Value, json};

use crate::field::FieldSpec;
use crate::grid::{Grid, Topology, vtk_type};
use crate::mesh::PolyMesh;
use crate::pipeline::SliceResult;
use crate::structures::CELL_CLASS_NAMES;
use crate::structures::Structure;

/// One value per polygon from its source cell: every polygon gets its own
/// copies of its vertices, all carrying the cell's value.
pub fn flatten_by_cell(m: &PolyMesh, cell_values: &[f64]) -> PolyMesh {
    let mut out = PolyMesh {
        origin: m.origin,
        property_name: m.property_name.clone(),
        poly_level: m.poly_level.clone(),
        level_values: m.level_values.clone(),
        poly_cell: m.poly_cell.clone(),
        ..Default::default()
    };
    out.poly_offsets.push(0);
    for p in 0..m.polygon_count() {
        let v = cell_values
            .get(m.poly_cell[p] as usize)
            .copied()
            .unwrap_or(f64::NAN) as f32;
        for &i in m.polygon(p) {
            out.poly_indices.push(out.positions.len() as u32);
            out.positions.push(m.positions[i as usize]);
            out.values.push(v);
        }
        out.poly_offsets.push(out.poly_indices.len() as u32);
    }
    out
}

/// The VTK name of a cell type id (`hexahedron`, `polyhedron`, ...).
pub fn type_name(t: u8) -> &'static str {
    match t {
        vtk_type::TETRA => "tetrahedron",
        vtk_type::VOXEL => "voxel",
        vtk_type::HEXAHEDRON => "hexahedron",
        vtk_type::WEDGE => "wedge",
        vtk_type::PYRAMID => "pyramid",
        vtk_type::PENTAGONAL_PRISM => "pentagonal_prism",
        vtk_type::HEXAGONAL_PRISM => "hexagonal_prism",
        vtk_type::POLYHEDRON => "polyhedron",
        1 => "vertex",
        2 => "poly_vertex",
        3 => "line",
        4 => "poly_line",
        5 => "triangle",
        6 => "triangle_strip",
        7 => "polygon",
        8 => "pixel",
        9 => "quad",
        _ => "other",
    }
}

/// Bytes per structure part, plus one f32 property per vertex and the
/// sweep's stamps, with their `total`; returns the JSON and the total.
pub fn memory_json(s: &Structure, grid: &Grid) -> (Value, usize) {
    let mut m = serde_json::Map::new();
    let mut total = 0;
    for (k, v) in s.bytes() {
        m.insert(k.to_string(), json!(v));
        total += v;
    }
    // One f32 property per vertex, as the sweep holds it.
    let prop = grid.points.len() * 4;
    m.insert("property_f32".into(), json!(prop));
    total += prop;
    // Step stamps (u16 per slot; CIEL: u32 per cell), allocated per sweep.
    let stamps = s.slot_count()
        * if matches!(s, Structure::Ciel(_)) {
            4
        } else {
            2
        };
    m.insert("stamps".into(), json!(stamps));
    total += stamps;
    m.insert("total".into(), json!(total));
    (Value::Object(m), total)
}

/// The statistics JSON of one slicing run (`slice --stats`): per level
/// cut cells, visits, polygons, triangles and area, totals, memory and
/// timings (`load` and `build` are the caller's).
pub fn stats_json(
    r: &SliceResult,
    s: &Structure,
    grid: &Grid,
    load: f64,
    build: f64,
    file: &str,
    field: &FieldSpec,
) -> Value {
    let slices: Vec<Value> = r
        .stats
        .iter()
        .enumerate()
        .map(|(k, st)| {
            json!({"index": k, "value": r.level_values[k], "cells": st.cells, "visited": st.visited,
                   "polygons": st.polygons, "triangles": st.triangles, "area": st.area})
        })
        .collect();
    let sum = |f: &dyn Fn(&crate::sweep::LevelStats) -> f64| r.stats.iter().map(f).sum::<f64>();
    let (mut mem, _) = memory_json(s, grid);
    let total = mem["total"].as_u64().unwrap_or(0) + r.sweep_state_bytes as u64;
    mem["sweep_state"] = json!(r.sweep_state_bytes);
    mem["total"] = json!(total);
    json!({
        "file": file,
        "structure": s.name(),
        "field": crate::pipeline::field_name(field),
        "attribute": r.attribute_name,
        "vertices": grid.points.len(),
        "cells": grid.cell_count(),
        "minima": r.minima,
        "slices": slices,
        "totals": {
            "cells": sum(&|s| s.cells as f64) as u64, "visited": sum(&|s| s.visited as f64) as u64,
            "polygons": sum(&|s| s.polygons as f64) as u64, "triangles": sum(&|s| s.triangles as f64) as u64,
            "area": sum(&|s| s.area),
        },
        "memory_bytes": mem,
        "cell_treatment": cell_treatment_json(s),
        "timings_s": {"load": load, "build": build, "field": r.timings.field, "minima": r.timings.minima, "sweep": r.timings.sweep},
    })
}

/// Sum of |volume| of the live cells, from their meta-cells (exact for
/// planar faces), in world units³.
pub fn live_volume(s: &Structure) -> f64 {
    use crate::sweep::CellGraph;
    fn sum<G: CellGraph>(g: &G) -> f64 {
        let pos = g.positions();
        let mut ids = [0u32; crate::metacell::MAX_META_VERTICES];
        let mut v = 0.0;
        for c in 0..g.slot_count() as u32 {
            if g.is_live(c) {
                let (m, _) = g.cell(c, &mut ids);
                let p0 = pos[ids[0] as usize];
                v += g
                    .catalog()
                    .get(m)
                    .signed_volume(&|k| {
                        let p = pos[ids[k] as usize];
                        [0, 1, 2].map(|a| (p[a] - p0[a]) as f64)
                    })
                    .abs();
            }
        }
        v
    }
    match s {
        Structure::SCGraph(g) => sum(g),
        Structure::CGraph(g) => sum(g),
        Structure::CpGraph(g) => sum(g.as_ref()),
        Structure::Ciel(g) => (0..g.cell_count() as u32)
            .filter(|&c| g.is_live(c))
            .map(|c| g.cell_volume(c).abs())
            .sum(),
    }
}

/// Cells per meta-cell id for a grid of `n` hexahedra (S-CGraph).
fn hex_only(n: usize) -> Vec<usize> {
    let mut v = vec![0; crate::metacell::builtin::HEXAHEDRON as usize + 1];
    v[crate::metacell::builtin::HEXAHEDRON as usize] = n;
    v
}

/// The catalog's meta-cells that have cells, with their tables and counts.
fn catalog_json(c: &crate::metacell::Catalog, counts: &[usize]) -> Value {
    let used = |i: usize| counts.get(i).is_some_and(|&n| n > 0);
    Value::Array(
        c.metas
            .iter()
            .enumerate()
            .filter(|(i, _)| used(*i))
            .map(|(i, m)| {
                json!({
                    "name": m.name,
                    "vertices": m.nv,
                    "faces": m.faces.len(),
                    "edges": m.edges.len(),
                    "codes": m.code_count(),
                    "ambiguous_codes": (0..m.code_count()).filter(|&c| m.config_is_ambiguous(c)).count(),
                    "loops": m.config_size.len(),
                    "table_bytes": m.table_bytes(),
                    "cells": counts[i],
                })
            })
            .collect(),
    )
}

/// What [`info_json`] reports besides the grid and its structure: the
/// caller's name for the grid, its corner-point load report and timings.
#[derive(Clone, Debug, Default)]
pub struct InfoContext {
    /// Name printed as `file`.
    pub name: String,
    /// The corner-point report of [`crate::io::Loaded::cornerpoint`].
    pub cornerpoint: Option<Value>,
    /// Seconds to load.
    pub load_s: f64,
    /// Seconds to build the structure.
    pub build_s: f64,
    /// CPU seconds to load, when measured.
    pub load_cpu_s: Option<f64>,
    /// CPU seconds to build, when measured.
    pub build_cpu_s: Option<f64>,
}

/// The `info --json` report: vertices, cells by type and class, the
/// meta-cell catalog, bounds, properties, memory per structure part, bulk
/// volume, CIEL counts and the convex split.
pub fn info_json(grid: &Grid, s: &Structure, c: &InfoContext) -> Value {
    let bulk_volume = match &c.cornerpoint {
        Some(i) => i["bulk_volume"].as_f64().unwrap_or(0.0),
        None => crate::cornerpoint::bulk_volume(grid),
    };
    let mut types = serde_json::Map::new();
    match &grid.topology {
        Topology::Structured { .. } => {
            types.insert("hexahedron".into(), json!(grid.cell_count()));
        }
        Topology::Unstructured(cells) => {
            let mut counts = std::collections::BTreeMap::new();
            for &t in &cells.types {
                *counts.entry(type_name(t)).or_insert(0usize) += 1;
            }
            for (k, v) in counts {
                types.insert(k.into(), json!(v));
            }
        }
    }
    let (classes, catalog, hidden) = match s {
        Structure::SCGraph(g) => (
            g.class_counts,
            catalog_json(
                crate::sweep::CellGraph::catalog(g),
                &hex_only(grid.cell_count()),
            ),
            grid.hidden_cells()
                .map_or(0, |h| h.iter().filter(|&&x| x).count()),
        ),
        Structure::CGraph(g) => (
            g.class_counts,
            catalog_json(&g.catalog, &g.meta_counts),
            g.hidden_count,
        ),
        Structure::Ciel(g) => (g.counts.class_counts, json!([]), g.counts.hidden),
        Structure::CpGraph(g) => (
            g.class_counts,
            catalog_json(&g.catalog, &g.meta_counts),
            g.hidden_count,
        ),
    };
    let (classes, left_handed) = handedness(classes, s);
    let (mem, total) = memory_json(s, grid);
    let nv = grid.points.len();
    let nc = grid.cell_count();
    // The paper's split: per-vertex arrays (positions, one f32 property)
    // against everything held per cell (connectivity, stamps, tables).
    let vertex_part = ["positions", "property_f32"]
        .iter()
        .map(|k| mem[*k].as_u64().unwrap_or(0) as usize)
        .sum::<usize>();
    let cell_part = total - vertex_part;
    let (lo, hi) = grid.bounds();
    let mut out = json!({
        "file": c.name,
        "structure": s.name(),
        "vertices": nv,
        "cells": nc,
        "live_cells": s.live_cells(),
        "hidden_cells": hidden,
        "cell_types": types,
        "handedness": if left_handed { "left-handed" } else { "right-handed" },
        "cell_classes": CELL_CLASS_NAMES.iter().zip(classes).map(|(k, v)| (k.to_string(), json!(v))).collect::<serde_json::Map<_, _>>(),
        "meta_cells": catalog,
        "bounds": {"min": lo, "max": hi},
        "point_properties": grid.point_data.iter().map(|p| &p.name).collect::<Vec<_>>(),
        "cell_properties": grid.cell_data.iter().map(|p| &p.name).collect::<Vec<_>>(),
        "memory_bytes": mem,
        "bytes_per_vertex": total as f64 / nv as f64,
        "bytes_per_cell": total as f64 / nc as f64,
        "bytes_split": {
            "per_vertex": vertex_part as f64 / nv as f64,
            "per_cell": cell_part as f64 / nc as f64,
        },
        "timings_s": {"load": c.load_s, "build": c.build_s},
        "cpu_s": {"load": c.load_cpu_s, "build": c.build_cpu_s},
        "bulk_volume": bulk_volume,
        "cornerpoint": c.cornerpoint,
    });
    if let Structure::Ciel(g) = s {
        out["half_edges"] = json!(g.half_edge_count());
        out["ciel"] = json!({
            "half_edges": g.half_edge_count(),
            "bytes_per_half_edge": crate::structures::ciel::BYTES_PER_HALF_EDGE,
            // With the vertex cycles (CSR of representatives) counted in.
            "bytes_per_half_edge_with_vertex_cycles": g.bytes().iter()
                .filter(|(k, _)| *k == "half_edges" || *k == "vertex_edges")
                .map(|(_, v)| *v).sum::<usize>() as f64 / g.half_edge_count() as f64,
            "edges": g.counts.edges,
            "faces": g.counts.faces,
            "border_half_edges": g.counts.border_half_edges,
            "flipped_faces": g.counts.flipped_faces,
            "non_convex_cells": g.counts.non_convex,
            "convexity_tolerance": crate::structures::ciel::CONVEXITY_TOLERANCE,
        });
    }
    if let Structure::CpGraph(g) = s {
        out["cpgraph"] = cpgraph_json(g);
    }
    let (bow_ties, n_bow_ties) = crate::structures::cell_check::self_intersecting_cells(grid, 20);
    out["self_intersecting_cells"] = json!({"count": n_bow_ties, "first": bow_ties});
    let (flipped, n_flipped, n_faces) =
        crate::structures::cell_check::reoriented_polyhedra(grid, 20);
    out["reoriented_polyhedra"] = json!({"count": n_flipped, "faces": n_faces, "first": flipped});
    // Non-convex polyhedra split into convex pieces before building.
    out["convex_split"] = s.split().map_or(Value::Null, |m| {
        let r = &m.report;
        json!({
            "non_convex_cells": r.non_convex,
            "pieces": r.pieces,
            "triangulated_faces": r.triangulated_faces,
            "kept_faces": r.kept_faces,
            "new_vertices": r.new_vertices,
            "vertex_pulled": r.vertex_pulled,
        })
    });
    out["cell_treatment"] = cell_treatment_json(s);
    out
}

/// A grid is left-handed when most of its cells have a mirrored vertex
/// order (negative volume); that is one fact about the grid, not a defect
/// of each cell: the classes then count the cells mirrored *relative to the
/// grid* as inverted and the others as valid. The S-CGraph reads a
/// left-handed grid with K reversed and says so itself.
fn handedness(
    mut classes: [usize; crate::structures::CELL_CLASS_COUNT],
    s: &Structure,
) -> ([usize; crate::structures::CELL_CLASS_COUNT], bool) {
    use crate::structures::CellClass::{Inverted, Valid};
    if let Structure::SCGraph(g) = s {
        return (classes, g.left_handed);
    }
    // Pieces of split cells are made positive whatever the grid's
    // handedness: they count as valid either way.
    let own = s
        .split()
        .map_or(0, |m| m.report.pieces + m.report.twisted_pieces);
    let (v, i) = (Valid as usize, Inverted as usize);
    let given = classes[v].saturating_sub(own);
    let left = classes[i] > given;
    if left {
        classes[v] = classes[i] + (classes[v] - given);
        classes[i] = given;
    }
    (classes, left)
}

/// How many cells were not sliced as given: twisted cells sliced through
/// their tetrahedral decomposition, non-convex cells that could not be
/// split (skipped), twisted cells the structure leaves unsliced; with the
/// structure's notes ([`Structure::cell_notes`]).
pub fn cell_treatment_json(s: &Structure) -> Value {
    let r = s.split().map(|m| m.report.clone()).unwrap_or_default();
    json!({
        "twisted_decomposed": r.twisted,
        "twisted_pieces": r.twisted_pieces,
        "twisted_first": r.twisted_first,
        "skipped_unsplittable": r.skipped,
        "skipped_first": r.skipped_first,
        "twisted_not_sliced": s.twisted_left(),
        "notes": s.cell_notes(),
    })
}

/// `info`'s figures of the corner-point graph: faces, exceptions, storage.
fn cpgraph_json(g: &crate::structures::cpgraph::CpGraph) -> Value {
    let c = &g.counts;
    json!({
        "dims": g.dims, "faces": c.faces, "conforming_faces": c.conforming_faces,
        "exception_faces": c.exception_faces, "linked_exception_faces": c.linked_exceptions,
        "stencils": c.stencils, "stencil_cells": c.stencil_cells,
        "explicit_cells": c.explicit_cells, "pieces": c.pieces,
        "bytes_per_live_cell": g.bytes().iter().map(|b| b.1).sum::<usize>() as f64
            / c.live_input_cells.max(1) as f64,
    })
}
