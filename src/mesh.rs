//! The output of a sweep: an indexed polygon mesh welded by grid edge.

/// Indexed polygons with per-vertex interpolated values and per-polygon
/// level and source cell. Positions are f32 relative to `origin` (f64), so
/// world coordinates are `origin + position`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PolyMesh {
    /// World-space origin the positions are relative to.
    pub origin: [f64; 3],
    /// Name of the interpolated property carried in `values`.
    pub property_name: String,
    /// Vertex positions relative to `origin`.
    pub positions: Vec<[f32; 3]>,
    /// Interpolated property per vertex.
    pub values: Vec<f32>,
    /// `poly_offsets[p]..poly_offsets[p+1]` indexes `poly_indices` (len = polygons + 1).
    pub poly_offsets: Vec<u32>,
    /// Vertex indices of every polygon, concatenated.
    pub poly_indices: Vec<u32>,
    /// Level index of each polygon.
    pub poly_level: Vec<u32>,
    /// Level value (world units) of each level index.
    pub level_values: Vec<f64>,
    /// Source cell id (in the input grid's numbering) of each polygon.
    pub poly_cell: Vec<u32>,
}

impl PolyMesh {
    /// Number of polygons.
    pub fn polygon_count(&self) -> usize {
        self.poly_offsets.len().saturating_sub(1)
    }
    /// Vertex indices of polygon `p`.
    pub fn polygon(&self, p: usize) -> &[u32] {
        &self.poly_indices[self.poly_offsets[p] as usize..self.poly_offsets[p + 1] as usize]
    }
    /// World position of vertex `v` (f64).
    pub fn world_position(&self, v: usize) -> [f64; 3] {
        let p = self.positions[v];
        [0, 1, 2].map(|a| self.origin[a] + p[a] as f64)
    }
}
