// GPU-only span-space variant (DESIGN §6): every live cell is binned into
// the levels it spans (lo < t ≤ hi, levels increasing) with no CPU sweep.
// bin_count totals the entries; bin_fill writes them (in no particular
// order) for the count, scan and emit passes.

// First level index whose value is above x.
fn first_above(x: f32) -> u32 {
    var lo = 0u;
    var hi = params.level_count;
    while lo < hi {
        let m = (lo + hi) / 2u;
        if levels[m] > x {
            hi = m;
        } else {
            lo = m + 1u;
        }
    }
    return lo;
}

// Level range [first, end) cut by live cell i.
fn span(i: u32) -> vec2<u32> {
    let nv = load_cell(live[i]).y;
    var lo = c_phi[0];
    var hi = c_phi[0];
    for (var j = 1u; j < nv; j++) {
        lo = min(lo, c_phi[j]);
        hi = max(hi, c_phi[j]);
    }
    return vec2<u32>(first_above(lo), first_above(hi));
}

@compute @workgroup_size(64)
fn bin_count(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = entry_index(gid);
    if i >= params.live_count {
        return;
    }
    let r = span(i);
    if r.y > r.x {
        atomicAdd(&control[ctl_bin_total()], r.y - r.x);
    }
}

@compute @workgroup_size(64)
fn bin_fill(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = entry_index(gid);
    if i >= params.live_count {
        return;
    }
    let r = span(i);
    if r.y > r.x {
        let at = atomicAdd(&control[ctl_bin_cursor()], r.y - r.x);
        let slot = live[i];
        for (var k = r.x; k < r.y; k++) {
            let w = at + k - r.x;
            if w < params.entry_count {
                entries[w] = Entry(slot, k);
            }
        }
    }
}
