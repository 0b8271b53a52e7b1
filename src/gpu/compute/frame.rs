//! What one emission frame produces (read back from the GPU or made by the
//! twin): the control words (draw arguments, counters) and the triangles
//! in per-level regions, plus helpers to compare and summarise them.

use crate::sweep::LevelStats;

use super::tables::Frame;
use crate::gpu::shared::{ControlLayout, DrawArgs, OutVertex};

/// The output of one frame.
#[derive(Clone, Debug, Default)]
pub struct FrameOutput {
    /// Level count.
    pub k: u32,
    /// The control buffer ([`ControlLayout`]).
    pub control: Vec<u32>,
    /// Triangle corners (3 per triangle), level regions back to back.
    pub vertices: Vec<OutVertex>,
    /// Per triangle: its share of its polygon's area (empty unless requested).
    pub areas: Vec<f32>,
    /// Per triangle corner (parallel to `vertices`): the interpolated
    /// gradient of the field (xyz, w = 0); empty unless the grid buffers
    /// carried gradients.
    pub normals: Vec<[f32; 4]>,
}

impl FrameOutput {
    fn layout(&self) -> ControlLayout {
        ControlLayout { k: self.k }
    }
    /// Draw arguments of level `lv` (increasing order array).
    pub fn args(&self, lv: u32) -> DrawArgs {
        let o = (self.layout().args_fwd() + 4 * lv) as usize;
        *bytemuck::from_bytes(bytemuck::cast_slice(&self.control[o..o + 4]))
    }
    /// Draw arguments at position `i` of the decreasing-order array.
    pub fn args_rev(&self, i: u32) -> DrawArgs {
        let o = (self.layout().args_rev() + 4 * i) as usize;
        *bytemuck::from_bytes(bytemuck::cast_slice(&self.control[o..o + 4]))
    }
    /// Polygons of level `lv`.
    pub fn polygons(&self, lv: u32) -> u32 {
        self.control[(self.layout().poly_count() + lv) as usize]
    }
    /// Triangles of all levels.
    pub fn total_triangles(&self) -> u32 {
        self.control[self.layout().total() as usize]
    }
    /// The triangles of level `lv`.
    pub fn level_vertices(&self, lv: u32) -> &[OutVertex] {
        let a = self.args(lv);
        &self.vertices[a.first_vertex as usize..(a.first_vertex + a.vertex_count) as usize]
    }
    /// The triangles of level `lv` with each corner's normal appended
    /// (position, value, normal xyz), in the canonical order of
    /// [`canonical`] keyed by position and value. Requires normals.
    pub fn canonical_level_with_normals(&self, lv: u32) -> Vec<[[f32; 7]; 3]> {
        let a = self.args(lv);
        let r = a.first_vertex as usize..(a.first_vertex + a.vertex_count) as usize;
        canonical_with_normals(&self.vertices[r.clone()], &self.normals[r])
    }
    /// The triangles of level `lv` in a canonical order: each rotated to
    /// start at its smallest corner (orientation kept), then sorted.
    pub fn canonical_level(&self, lv: u32) -> Vec<[[f32; 4]; 3]> {
        canonical(self.level_vertices(lv))
    }
    /// Per-level statistics: cells from the frame, polygons and triangles
    /// from the counters, areas summed (f64) from the per-triangle shares.
    pub fn stats(&self, frame: &Frame) -> Vec<LevelStats> {
        let mut st = vec![LevelStats::default(); self.k as usize];
        for e in &frame.entries {
            st[e.level as usize].cells += 1;
        }
        for lv in 0..self.k {
            let s = &mut st[lv as usize];
            let a = self.args(lv);
            s.visited = frame.visited.get(lv as usize).copied().unwrap_or(0);
            s.polygons = self.polygons(lv) as u64;
            s.triangles = (a.vertex_count / 3) as u64;
            if !self.areas.is_empty() {
                let t0 = (a.first_vertex / 3) as usize;
                s.area = self.areas[t0..t0 + s.triangles as usize]
                    .iter()
                    .map(|&x| x as f64)
                    .sum();
            }
        }
        st
    }
}

fn key(v: &[f32; 4]) -> [u32; 4] {
    v.map(f32::to_bits)
}

/// Triangles (3 corners each) in canonical order: each rotated to start at
/// its smallest corner by bit pattern (orientation kept), then sorted.
pub fn canonical(vertices: &[OutVertex]) -> Vec<[[f32; 4]; 3]> {
    let mut tris: Vec<[[f32; 4]; 3]> = vertices
        .chunks_exact(3)
        .map(|c| {
            let p: [[f32; 4]; 3] =
                std::array::from_fn(|i| [c[i].pos[0], c[i].pos[1], c[i].pos[2], c[i].value]);
            let r = (0..3).min_by_key(|&i| key(&p[i])).unwrap_or(0);
            [p[r], p[(r + 1) % 3], p[(r + 2) % 3]]
        })
        .collect();
    tris.sort_by_key(|t| t.map(|v| key(&v)));
    tris
}

/// As [`canonical`], each corner carrying its normal (position, value,
/// normal xyz); the order keys on position and value only.
pub fn canonical_with_normals(vertices: &[OutVertex], normals: &[[f32; 4]]) -> Vec<[[f32; 7]; 3]> {
    let mut tris: Vec<[[f32; 7]; 3]> = vertices
        .chunks_exact(3)
        .zip(normals.chunks_exact(3))
        .map(|(c, n)| {
            let p: [[f32; 7]; 3] = std::array::from_fn(|i| {
                [
                    c[i].pos[0],
                    c[i].pos[1],
                    c[i].pos[2],
                    c[i].value,
                    n[i][0],
                    n[i][1],
                    n[i][2],
                ]
            });
            let k = |v: &[f32; 7]| key(&[v[0], v[1], v[2], v[3]]);
            let r = (0..3).min_by_key(|&i| k(&p[i])).unwrap_or(0);
            [p[r], p[(r + 1) % 3], p[(r + 2) % 3]]
        })
        .collect();
    tris.sort_by_key(|t| t.map(|v| key(&[v[0], v[1], v[2], v[3]])));
    tris
}
