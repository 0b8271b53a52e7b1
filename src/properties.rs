//! Property transfer: per-cell values to the vertices by volume-weighted
//! averaging over the live cells that share each vertex.

use crate::cellgraph::CellGraph;
use crate::metacell::MAX_META_VERTICES;

/// Volume-weighted average of `cell_values` (indexed by source cell id) at
/// each vertex, over the live cells incident to it. Vertices of no live
/// cell get the mean of all values.
pub fn cell_to_vertex<G: CellGraph>(g: &G, cell_values: &[f64], vertex_count: usize) -> Vec<f32> {
    let mut sum = vec![0.0f64; vertex_count];
    let mut wsum = vec![0.0f64; vertex_count];
    let pos = g.positions();
    let mut ids = [0u32; MAX_META_VERTICES];
    for s in 0..g.slot_count() as u32 {
        if !g.is_live(s) {
            continue;
        }
        let (m, n) = g.cell(s, &mut ids);
        let meta = g.catalog().get(m);
        let vol = meta
            .signed_volume(&|v| pos[ids[v] as usize].map(f64::from))
            .abs();
        let Some(&val) = cell_values.get(g.source_cell(s) as usize) else {
            continue;
        };
        for &v in &ids[..n] {
            sum[v as usize] += vol * val;
            wsum[v as usize] += vol;
        }
    }
    weighted_means(&sum, &wsum, cell_values)
}

/// Per vertex `sum / wsum` (the volume-weighted average gathered by a
/// caller); vertices with no weight get the mean of all `cell_values`.
pub(crate) fn weighted_means(sum: &[f64], wsum: &[f64], cell_values: &[f64]) -> Vec<f32> {
    let mean = cell_values.iter().sum::<f64>() / cell_values.len().max(1) as f64;
    sum.iter()
        .zip(wsum)
        .map(|(&s, &w)| if w > 0.0 { (s / w) as f32 } else { mean as f32 })
        .collect()
}
