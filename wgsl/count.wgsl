// Pass 1: per (level, cell) entry, count its triangles and polygons into the
// per-level counters.

@compute @workgroup_size(64)
fn count(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = entry_index(gid);
    if i >= params.entry_count {
        return;
    }
    let e = entries[i];
    let t = levels[e.level];
    let r = cell_variant(e, t);
    let l0 = tables[params.tables.variants + r.x];
    let l1 = tables[params.tables.variants + r.x + 1u];
    atomicAdd(&control[ctl_tri_count() + e.level], variant_triangles(r.x));
    atomicAdd(&control[ctl_poly_count() + e.level], l1 - l0);
}
