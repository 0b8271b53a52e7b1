//! `stratasweep info`: what a grid holds, its cell classes and structures.

use super::bench::*;
use super::checks::Outputs;
use super::common::*;
use anyhow::Result;
use clap::Args;
use std::time::Instant;

#[derive(Args)]
pub(crate) struct InfoArgs {
    #[command(flatten)]
    pub(crate) input: GridArg,
    /// Structure whose memory is reported.
    #[arg(long, value_enum, default_value = "auto")]
    pub(crate) structure: StructureArg,
    /// Print JSON.
    #[arg(long)]
    pub(crate) json: bool,
}

pub(crate) fn cmd_info(a: InfoArgs) -> Result<()> {
    let cpu0 = process_cpu_ns();
    let (grid, name, load_s, cp, ijk) = load_with_info(&a.input, true, &Outputs::default())?;
    let cpu1 = process_cpu_ns();
    let t = Instant::now();
    let s = build_structure(&grid, a.structure.into(), ijk.as_ref(), &name, true)?;
    let build_s = t.elapsed().as_secs_f64();
    let cpu2 = process_cpu_ns();
    let cpu_s = |a: Option<u64>, b: Option<u64>| match (a, b) {
        (Some(a), Some(b)) => Some(b.saturating_sub(a) as f64 * 1e-9),
        _ => None,
    };
    let out = stratasweep::report::info_json(
        &grid,
        &s,
        &stratasweep::report::InfoContext {
            name: name.clone(),
            cornerpoint: cp.clone(),
            load_s,
            build_s,
            load_cpu_s: cpu_s(cpu0, cpu1),
            build_cpu_s: cpu_s(cpu1, cpu2),
        },
    );
    let (nv, nc) = (grid.points.len(), grid.cell_count());
    let (hidden, bulk_volume) = (&out["hidden_cells"], &out["bulk_volume"]);
    let (lo, hi) = grid.bounds();
    let total = out["memory_bytes"]["total"].as_f64().unwrap_or(0.0);
    let split = &out["bytes_split"];
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!("{name}");
    println!("  vertices      {nv}");
    println!(
        "  cells         {nc} ({} live, {hidden} hidden)",
        s.live_cells()
    );
    for (k, v) in out["cell_types"].as_object().unwrap() {
        println!("    {k:<18} {v}");
    }
    if out["handedness"] == "left-handed" {
        println!(
            "  handedness    left-handed (cells' vertex order mirrored; read as such, classes relative to it)"
        );
    }
    println!("  cell classes  {}", out["cell_classes"]);
    for note in out["cell_treatment"]["notes"]
        .as_array()
        .into_iter()
        .flatten()
    {
        println!("  note: {}", note.as_str().unwrap_or_default());
    }
    let turned = &out["reoriented_polyhedra"];
    if turned["count"].as_u64().unwrap_or(0) > 0 {
        println!(
            "  polyhedra with faces given inward (re-oriented outward before slicing): {}, {} faces, first ids {}",
            turned["count"], turned["faces"], turned["first"]
        );
    }
    let bow_ties = &out["self_intersecting_cells"];
    if bow_ties["count"].as_u64().unwrap_or(0) > 0 {
        let how = if out["cell_treatment"]["twisted_not_sliced"] == 0 {
            "sliced through a tetrahedral decomposition"
        } else {
            "not sliced"
        };
        println!(
            "  self-intersecting cells (a face crosses itself; {how}): {}, first ids {}",
            bow_ties["count"], bow_ties["first"]
        );
    }
    println!("  bulk volume   {bulk_volume}");
    if let Some(i) = &cp {
        println!(
            "  corner-point  dims {} classes {}",
            i["dims"], i["classes"]
        );
        println!("    skipped keywords {}", i["input"]["skipped_keywords"]);
    }
    println!("  bounds        {lo:?} .. {hi:?}");
    println!(
        "  properties    point {} / cell {}",
        out["point_properties"], out["cell_properties"]
    );
    println!("  meta-cells");
    for m in out["meta_cells"].as_array().unwrap() {
        println!(
            "    {:<22} nv {:>2}  faces {:>2}  codes {:>5}  ambiguous {:>5}  table {} B  cells {}",
            m["name"].as_str().unwrap(),
            m["vertices"],
            m["faces"],
            m["codes"],
            m["ambiguous_codes"],
            m["table_bytes"],
            m["cells"]
        );
    }
    println!(
        "  structure     {} ({:.1} B/vertex, {:.1} B/cell in all; split {:.1} B/vertex + {:.1} B/cell)",
        s.name(),
        total / nv as f64,
        total / nc as f64,
        split["per_vertex"].as_f64().unwrap_or(0.0),
        split["per_cell"].as_f64().unwrap_or(0.0)
    );
    for (k, v) in out["memory_bytes"].as_object().unwrap() {
        println!("    {k:<30} {v}");
    }
    if !out["ciel"].is_null() {
        println!("  ciel          {}", out["ciel"]);
    }
    if !out["cpgraph"].is_null() {
        println!("  cpgraph       {}", out["cpgraph"]);
    }
    if !out["convex_split"].is_null() {
        println!("  convex split  {}", out["convex_split"]);
    }
    Ok(())
}
