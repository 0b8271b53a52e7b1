//! The run's output mesh in canonical order: what each sweep block (or
//! CIEL thread) emitted per level, kept as flat copies of its level meshes
//! ([`LevelCopy`]), merged into one [`PolyMesh`] whose polygons and vertices
//! do not depend on the number of blocks.

use crate::extract::{EdgeMap, LevelMesh};
use crate::mem::{AllocError, try_grow, try_reserve};
use crate::mesh::PolyMesh;

/// One level's polygons from one part of a run: the arrays of its
/// [`LevelMesh`] (vertices with their grid edge keys, polygons with their
/// slots), and each polygon's input cell.
#[derive(Clone, Debug, Default)]
pub(super) struct LevelCopy {
    keys: Vec<u64>,
    positions: Vec<[f32; 3]>,
    values: Vec<f32>,
    /// `offsets[p]..offsets[p + 1]` indexes `indices` (empty: no polygon).
    offsets: Vec<u32>,
    indices: Vec<u32>,
    slots: Vec<u32>,
    sources: Vec<u32>,
    /// Level meshes appended: with one, each edge key is one vertex (a
    /// [`LevelMesh`] is welded by grid edge).
    meshes: u32,
}

impl LevelCopy {
    /// Appends the polygons of `mesh`, `source` giving a slot's input cell,
    /// or says which array could not grow (the copy then holds a prefix of
    /// the level: the run is abandoned).
    pub(super) fn append(
        &mut self,
        mesh: &LevelMesh,
        source: impl Fn(u32) -> u32,
    ) -> Result<(), AllocError> {
        let polygons = mesh.polygon_count();
        if polygons == 0 {
            return Ok(());
        }
        let (nv, used) = (mesh.positions.len(), mesh.offsets[polygons] as usize);
        try_grow(&mut self.keys, nv, "the sliced vertices' edge keys")?;
        try_grow(&mut self.positions, nv, "the sliced vertices' positions")?;
        try_grow(&mut self.values, nv, "the sliced vertices' values")?;
        try_grow(&mut self.indices, used, "the slice polygons' corners")?;
        try_grow(
            &mut self.offsets,
            polygons + 1,
            "the slice polygons' offsets",
        )?;
        try_grow(&mut self.slots, polygons, "the slice polygons' slots")?;
        try_grow(&mut self.sources, polygons, "the slice polygons' cells")?;
        let (v0, i0) = (self.positions.len() as u32, self.indices.len() as u32);
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.keys.extend_from_slice(&mesh.edge_keys);
        self.positions.extend_from_slice(&mesh.positions);
        self.values.extend_from_slice(&mesh.values);
        self.indices
            .extend(mesh.indices[..used].iter().map(|&v| v0 + v));
        self.offsets
            .extend(mesh.offsets[1..=polygons].iter().map(|&o| i0 + o));
        self.slots.extend_from_slice(&mesh.cells[..polygons]);
        self.sources
            .extend(mesh.cells[..polygons].iter().map(|&s| source(s)));
        self.meshes += 1;
        Ok(())
    }

    /// Polygons held.
    fn polygons(&self) -> usize {
        self.slots.len()
    }
}

/// Merges the parts' level copies into one mesh: per level, polygons in
/// (input cell, slot) order, stable (the parts' order, then each part's
/// emission order), vertices welded by grid edge in first-use order. The
/// result does not depend on the number of blocks. `levels(part, lv)` is
/// the part's copy of level `lv`, if it has one. The output's arrays are
/// allocated first, fallibly: an [`AllocError`] names the one that did not
/// fit.
pub(super) fn canonical_mesh<'a>(
    parts: usize,
    levels: impl Fn(usize, usize) -> Option<&'a LevelCopy>,
    world: &[f64],
) -> Result<PolyMesh, AllocError> {
    let mut m = PolyMesh {
        poly_offsets: vec![0],
        level_values: world.to_vec(),
        ..Default::default()
    };
    // Room for everything at once (the vertices: at most the copies'), so
    // the big arrays are not regrown and copied.
    let [mut polygons, mut corners, mut vertices] = [0usize; 3];
    for lv in 0..world.len() {
        for c in (0..parts).filter_map(|p| levels(p, lv)) {
            polygons += c.polygons();
            corners += c.indices.len();
            vertices += c.positions.len();
        }
    }
    try_reserve(&mut m.poly_offsets, polygons, "the slice polygons' offsets")?;
    try_reserve(&mut m.poly_level, polygons, "the slice polygons' levels")?;
    try_reserve(&mut m.poly_cell, polygons, "the slice polygons' cells")?;
    try_reserve(&mut m.poly_indices, corners, "the slice polygons' corners")?;
    try_reserve(&mut m.positions, vertices, "the slice vertices' positions")?;
    try_reserve(&mut m.values, vertices, "the slice vertices' values")?;
    let mut weld = EdgeMap::default();
    // Edge keys of this level's output vertices (the weld's values index it).
    let mut level_keys: Vec<u64> = Vec::new();
    // Per part: its vertices' output index at this level, once looked up.
    let mut canon: Vec<Vec<u32>> = vec![Vec::new(); parts];
    let mut order: Vec<(u64, u32, u32)> = Vec::new();
    let mut copies: Vec<Option<&LevelCopy>> = Vec::with_capacity(parts);
    for lv in 0..world.len() {
        copies.clear();
        copies.extend((0..parts).map(|p| levels(p, lv)));
        order.clear();
        for (p, c) in copies.iter().enumerate() {
            let Some(c) = c else { continue };
            order.extend((0..c.polygons()).map(|i| {
                (
                    (c.sources[i] as u64) << 32 | c.slots[i] as u64,
                    p as u32,
                    i as u32,
                )
            }));
            canon[p].clear();
            canon[p].resize(c.positions.len(), u32::MAX);
        }
        // Stable: ties keep the parts' order, then the emission order.
        if !order.is_sorted_by_key(|o| o.0) {
            order.sort_by_key(|o| o.0);
        }
        weld.clear();
        level_keys.clear();
        let base = m.positions.len() as u32;
        // One level mesh alone is welded already: number its vertices in
        // first-use order, without looking their keys up.
        let alone = copies.iter().flatten().map(|c| c.meshes).sum::<u32>() == 1;
        for &(key, p, i) in &order {
            let c = copies[p as usize].expect("ordered polygons come from present copies");
            let (a, b) = (
                c.offsets[i as usize] as usize,
                c.offsets[i as usize + 1] as usize,
            );
            for &v in &c.indices[a..b] {
                let slot = &mut canon[p as usize][v as usize];
                if *slot == u32::MAX && alone {
                    *slot = m.positions.len() as u32;
                    m.positions.push(c.positions[v as usize]);
                    m.values.push(c.values[v as usize]);
                } else if *slot == u32::MAX {
                    weld.reserve(1, &level_keys);
                    let next = level_keys.len() as u32;
                    let (local, new) = weld.get_or_insert(c.keys[v as usize], next, &level_keys);
                    if new {
                        level_keys.push(c.keys[v as usize]);
                        m.positions.push(c.positions[v as usize]);
                        m.values.push(c.values[v as usize]);
                    }
                    *slot = base + local;
                }
                m.poly_indices.push(*slot);
            }
            m.poly_offsets.push(m.poly_indices.len() as u32);
            m.poly_level.push(lv as u32);
            m.poly_cell.push((key >> 32) as u32);
        }
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// A level mesh of random polygons over `nv` (at most 40) vertices with
    /// distinct edge keys from a small set, slots in random order.
    fn random_mesh(seed: &mut u64, nv: usize, polygons: usize) -> LevelMesh {
        let mut next = move || {
            *seed ^= *seed << 13;
            *seed ^= *seed >> 7;
            *seed ^= *seed << 17;
            *seed
        };
        let mut m = LevelMesh::default();
        // Distinct keys within the mesh (it is welded by edge), drawn from
        // 40, so that other meshes share some.
        let mut keys: Vec<u64> = (0..40).collect();
        for v in 0..nv {
            let pick = v + (next() % (40 - v) as u64) as usize;
            keys.swap(v, pick);
            m.edge_keys.push(keys[v]);
            m.positions.push([v as f32, next() as f32, 0.5]);
            m.values.push(next() as f32);
        }
        m.offsets = vec![0];
        for _ in 0..polygons {
            let n = 3 + (next() % 4) as usize;
            for _ in 0..n {
                m.indices.push((next() % nv as u64) as u32);
            }
            m.offsets.push(m.indices.len() as u32);
            m.cells.push((next() % 12) as u32);
        }
        m
    }

    /// The merge as first written: per level, (input cell, slot, corners)
    /// stably sorted, welded through a `HashMap` by edge key.
    fn reference(parts: &[Vec<Vec<LevelMesh>>], source: fn(u32) -> u32, k: usize) -> PolyMesh {
        let mut m = PolyMesh {
            poly_offsets: vec![0],
            level_values: (0..k).map(|l| l as f64).collect(),
            ..Default::default()
        };
        for lv in 0..k {
            let mut polys = Vec::new();
            for part in parts {
                for mesh in &part[lv] {
                    for p in 0..mesh.polygon_count() {
                        let ids =
                            &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
                        let corners: Vec<_> = ids
                            .iter()
                            .map(|&i| {
                                (
                                    mesh.edge_keys[i as usize],
                                    mesh.positions[i as usize],
                                    mesh.values[i as usize],
                                )
                            })
                            .collect();
                        polys.push((source(mesh.cells[p]), mesh.cells[p], corners));
                    }
                }
            }
            polys.sort_by_key(|p| (p.0, p.1));
            let mut weld: HashMap<u64, u32> = HashMap::new();
            for (cell, _, corners) in polys {
                for (key, pos, val) in corners {
                    let next = m.positions.len() as u32;
                    let vi = *weld.entry(key).or_insert(next);
                    if vi == next {
                        m.positions.push(pos);
                        m.values.push(val);
                    }
                    m.poly_indices.push(vi);
                }
                m.poly_offsets.push(m.poly_indices.len() as u32);
                m.poly_level.push(lv as u32);
                m.poly_cell.push(cell);
            }
        }
        m
    }

    #[test]
    fn merge_matches_the_hash_map_reference() {
        let source = |s: u32| s / 3;
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        for parts_n in 1..4 {
            let k = 5;
            // Per part, per level: one or two level meshes appended.
            let parts: Vec<Vec<Vec<LevelMesh>>> = (0..parts_n)
                .map(|_| {
                    (0..k)
                        .map(|lv| {
                            let appends = 1 + (lv % 2);
                            (0..appends)
                                .map(|_| random_mesh(&mut seed, 1 + lv * 7, lv * 5))
                                .collect()
                        })
                        .collect()
                })
                .collect();
            let copies: Vec<Vec<LevelCopy>> = parts
                .iter()
                .map(|part| {
                    part.iter()
                        .map(|meshes| {
                            let mut c = LevelCopy::default();
                            for mesh in meshes {
                                c.append(mesh, source).unwrap();
                            }
                            c
                        })
                        .collect()
                })
                .collect();
            let world: Vec<f64> = (0..k).map(|l| l as f64).collect();
            let got = canonical_mesh(parts_n, |p, lv| copies[p].get(lv), &world).unwrap();
            let want = reference(&parts, source, k);
            assert!(
                got.polygon_count() > 20,
                "{parts_n} parts: too few polygons to test"
            );
            assert!(
                got.positions.len() < got.poly_indices.len(),
                "no vertex was shared"
            );
            assert_eq!(got.positions, want.positions, "{parts_n} parts");
            assert_eq!(got.values, want.values);
            assert_eq!(got.poly_offsets, want.poly_offsets);
            assert_eq!(got.poly_indices, want.poly_indices);
            assert_eq!(got.poly_level, want.poly_level);
            assert_eq!(got.poly_cell, want.poly_cell);
        }
    }
}
