//! The CPU twin of the count, scan and emit passes (`wgsl/count.wgsl`,
//! `wgsl/scan.wgsl`, `wgsl/emit.wgsl`): the same buffers ([`GridBuffers`],
//! [`Frame`], [`EmitParams`]), the same control layout and the same loop,
//! entry after entry. The face decider is the CPU's own
//! [`extract::face_above_connected`](crate::extract::face_above_connected).

use crate::extract::face_above_connected;

use super::frame::FrameOutput;
use super::tables::{Frame, GridBuffers};
use crate::gpu::shared::{
    ATTR_CELL, ATTR_VERTEX, ControlLayout, DrawArgs, EmitParams, Entry, META_WORDS, MetaInfo,
    OutVertex,
};

/// Per-invocation state: the current cell's vertex ids and φ.
struct Cell {
    ids: [u32; 12],
    phi: [f32; 12],
}

struct Twin<'a> {
    p: &'a EmitParams,
    g: &'a GridBuffers,
}

impl Twin<'_> {
    fn t(&self, i: u32) -> u32 {
        self.g.tables[i as usize]
    }

    fn meta(&self, m: u32) -> MetaInfo {
        let b = (self.p.tables.metas + m * META_WORDS) as usize;
        *bytemuck::from_bytes(bytemuck::cast_slice(
            &self.g.tables[b..b + META_WORDS as usize],
        ))
    }

    fn decide_faces(&self, c: &Cell, mi: &MetaInfo, amb: u32, t: f32) -> u32 {
        let mut outcome = 0;
        let mut mask = amb;
        let mut bit = 0;
        while mask != 0 {
            let f = mask.trailing_zeros();
            mask &= mask - 1;
            let fs = self.p.tables.face_start + mi.face_base + f;
            let (a, b) = (self.t(fs), self.t(fs + 1));
            let mut v = [0f32; 12];
            let mut g = [0u32; 12];
            let n = (b - a) as usize;
            for i in 0..n {
                let l = self.t(self.p.tables.face_verts + a + i as u32) as usize;
                v[i] = c.phi[l];
                g[i] = c.ids[l];
            }
            if face_above_connected(&v[..n], &g[..n], t) {
                outcome |= 1 << bit;
            }
            bit += 1;
        }
        outcome
    }

    /// `cell_variant` of `wgsl/shared/cell.wgsl`.
    fn cell_variant(&self, e: Entry, t: f32, c: &mut Cell) -> (u32, u32) {
        let p = self.p;
        let (m, nv) = if p.structured == 1 {
            let v0 = e.slot - p.slab;
            for i in 0..4 {
                c.ids[i] = v0 + p.hex_offsets_lo[i];
                c.ids[i + 4] = v0 + p.hex_offsets_hi[i];
            }
            (p.hex_meta, 8)
        } else {
            let m = self.g.cells[2 * e.slot as usize];
            let start = self.g.cells[2 * e.slot as usize + 1] as usize;
            let nv = self.meta(m).nv as usize;
            c.ids[..nv].copy_from_slice(&self.g.cells[start..start + nv]);
            (m, nv)
        };
        let mut code = 0u32;
        for i in 0..nv {
            let ph = self.g.grid[c.ids[i] as usize][3];
            c.phi[i] = ph;
            if ph >= t {
                code |= 1 << i;
            }
        }
        let mi = self.meta(m);
        let ci = p.tables.codes + mi.code_base + 2 * code;
        let amb = self.t(ci);
        let mut variant = self.t(ci + 1);
        if amb != 0 {
            variant += self.decide_faces(c, &mi, amb, t);
        }
        (variant, m)
    }

    fn loops(&self, variant: u32) -> std::ops::Range<u32> {
        self.t(self.p.tables.variants + variant)..self.t(self.p.tables.variants + variant + 1)
    }

    fn variant_triangles(&self, variant: u32) -> u32 {
        self.loops(variant)
            .map(|l| self.t(self.p.tables.loops + 2 * l + 1) - 2)
            .sum()
    }

    /// `edge_point` of `wgsl/emit.wgsl` (the rule of `extract::push_vertex`):
    /// the corner and its interpolated gradient (zero without gradients).
    fn edge_point(
        &self,
        c: &Cell,
        mi: &MetaInfo,
        e: u32,
        t: f32,
        cell_value: f32,
    ) -> (OutVertex, [f32; 4]) {
        let packed = self.t(self.p.tables.edges + mi.edge_base + e);
        let (la, lb) = ((packed & 0xffff) as usize, (packed >> 16) as usize);
        let (mut ga, mut gb) = (c.ids[la], c.ids[lb]);
        let (mut fa, mut fb) = (c.phi[la], c.phi[lb]);
        if ga > gb {
            std::mem::swap(&mut ga, &mut gb);
            std::mem::swap(&mut fa, &mut fb);
        }
        let s = (t - fa) / (fb - fa);
        let pa = self.g.grid[ga as usize];
        let pb = self.g.grid[gb as usize];
        let value = match self.p.has_attribute {
            ATTR_VERTEX => {
                let a = &self.g.attr;
                a[ga as usize] + s * (a[gb as usize] - a[ga as usize])
            }
            ATTR_CELL => cell_value,
            _ => t + self.p.level_offset,
        };
        let mut n = [0f32; 4];
        if self.p.has_gradient == 1 {
            let na = self.g.grad[ga as usize];
            let nb = self.g.grad[gb as usize];
            for i in 0..3 {
                n[i] = na[i] + s * (nb[i] - na[i]);
            }
        }
        (
            OutVertex {
                pos: [
                    pa[0] + s * (pb[0] - pa[0]),
                    pa[1] + s * (pb[1] - pa[1]),
                    pa[2] + s * (pb[2] - pa[2]),
                ],
                value,
            },
            n,
        )
    }
}

/// Runs count, scan and emit on the CPU over the same buffers as the GPU,
/// with room for every triangle (the host reads the total after the scan).
pub fn run(g: &GridBuffers, frame: &Frame, write_areas: bool) -> FrameOutput {
    let mut p = super::tables::emit_params(g, frame, 0, write_areas, 1);
    let k = p.level_count;
    let lay = ControlLayout { k };
    let mut control = vec![0u32; lay.words() as usize];
    let mut cell = Cell {
        ids: [0; 12],
        phi: [0.0; 12],
    };
    // Count.
    {
        let tw = Twin { p: &p, g };
        for &e in &frame.entries {
            let t = frame.levels[e.level as usize];
            let (v, _) = tw.cell_variant(e, t, &mut cell);
            control[(lay.tri_count() + e.level) as usize] += tw.variant_triangles(v);
            control[(lay.poly_count() + e.level) as usize] += tw.loops(v).len() as u32;
        }
    }
    // Scan.
    let mut base = 0u32;
    for j in 0..k {
        let n = control[(lay.tri_count() + j) as usize];
        control[(lay.base() + j) as usize] = base;
        let args = DrawArgs {
            vertex_count: 3 * n,
            instance_count: 1,
            first_vertex: 3 * base,
            first_instance: 0,
        };
        let fwd = (lay.args_fwd() + 4 * j) as usize;
        let rev = (lay.args_rev() + 4 * (k - 1 - j)) as usize;
        control[fwd..fwd + 4].copy_from_slice(bytemuck::cast_slice(&[args]));
        control[rev..rev + 4].copy_from_slice(bytemuck::cast_slice(&[args]));
        base += n;
    }
    control[lay.total() as usize] = base;
    p.triangle_capacity = base;
    // Emit.
    let tw = Twin { p: &p, g };
    let mut vertices = vec![OutVertex::default(); 3 * base as usize];
    let mut areas = vec![0f32; if write_areas { base as usize } else { 0 }];
    let with_normals = p.has_gradient == 1;
    let mut normals = vec![[0f32; 4]; if with_normals { 3 * base as usize } else { 0 }];
    for &e in &frame.entries {
        let t = frame.levels[e.level as usize];
        let (v, m) = tw.cell_variant(e, t, &mut cell);
        let mi = tw.meta(m);
        let tris = tw.variant_triangles(v);
        let ci = (lay.cursor() + e.level) as usize;
        let mut tri = control[(lay.base() + e.level) as usize] + control[ci];
        let cell_value = if p.has_attribute == ATTR_CELL {
            g.attr[e.slot as usize]
        } else {
            0.0
        };
        control[ci] += tris;
        for l in tw.loops(v) {
            let cs = p.tables.config + tw.t(p.tables.loops + 2 * l);
            let n = tw.t(p.tables.loops + 2 * l + 1);
            let p0 = tw.edge_point(&cell, &mi, tw.t(cs), t, cell_value);
            let mut prev = tw.edge_point(&cell, &mi, tw.t(cs + 1), t, cell_value);
            let mut nrm = [0f32; 3];
            let first = tri;
            for j in 2..n {
                let cur = tw.edge_point(&cell, &mi, tw.t(cs + j), t, cell_value);
                if tri < p.triangle_capacity {
                    let o = 3 * tri as usize;
                    vertices[o] = p0.0;
                    vertices[o + 1] = prev.0;
                    vertices[o + 2] = cur.0;
                    if with_normals {
                        normals[o] = p0.1;
                        normals[o + 1] = prev.1;
                        normals[o + 2] = cur.1;
                    }
                }
                let u = sub(prev.0.pos, p0.0.pos);
                let w = sub(cur.0.pos, p0.0.pos);
                nrm[0] += u[1] * w[2] - u[2] * w[1];
                nrm[1] += u[2] * w[0] - u[0] * w[2];
                nrm[2] += u[0] * w[1] - u[1] * w[0];
                prev = cur;
                tri += 1;
            }
            if write_areas {
                let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
                let share = 0.5 * len / (n - 2) as f32;
                for a in &mut areas[first as usize..tri as usize] {
                    *a = share;
                }
            }
        }
    }
    FrameOutput {
        k,
        control,
        vertices,
        areas,
        normals,
    }
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The twin of `wgsl/bin.wgsl`: every live cell binned into the levels it
/// spans (`lo < t ≤ hi`), in live-slot order then level order (the GPU
/// writes the same set in another order).
pub fn bin(g: &GridBuffers, levels: &[f32]) -> Vec<Entry> {
    let p = super::tables::emit_params(g, &Frame::default(), 0, false, 1);
    let tw = Twin { p: &p, g };
    let mut out = Vec::new();
    for &slot in &g.live {
        let (lo, hi) = tw.span_of(slot);
        let a = levels.partition_point(|&t| t <= lo);
        let b = levels.partition_point(|&t| t <= hi);
        out.extend((a..b).map(|k| Entry {
            slot,
            level: k as u32,
        }));
    }
    out
}

impl Twin<'_> {
    /// φ extremes of the cell in `slot` (`span` of `wgsl/bin.wgsl`).
    fn span_of(&self, slot: u32) -> (f32, f32) {
        let mut c = Cell {
            ids: [0; 12],
            phi: [0.0; 12],
        };
        // The same load as cell_variant; the level value does not matter.
        let e = Entry { slot, level: 0 };
        let _ = self.cell_variant(e, 0.0, &mut c);
        let nv = if self.p.structured == 1 {
            8
        } else {
            self.meta(self.g.cells[2 * slot as usize]).nv as usize
        };
        let mut lo = c.phi[0];
        let mut hi = c.phi[0];
        for &x in &c.phi[1..nv] {
            lo = lo.min(x);
            hi = hi.max(x);
        }
        (lo, hi)
    }
}
