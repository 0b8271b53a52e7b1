// Pass 2 (one work group): exclusive prefix sum of the per-level triangle
// counts; writes each level's base and its DrawIndirectArgs in increasing
// and in decreasing level order, and the total.

var<workgroup> partial: array<u32, 256>;

@compute @workgroup_size(256)
fn scan(@builtin(local_invocation_index) li: u32) {
    let k = params.level_count;
    let per = (k + SCAN_WORKGROUP - 1u) / SCAN_WORKGROUP;
    let a = min(li * per, k);
    let b = min(a + per, k);
    var s = 0u;
    for (var j = a; j < b; j++) {
        s += atomicLoad(&control[ctl_tri_count() + j]);
    }
    partial[li] = s;
    workgroupBarrier();
    if li == 0u {
        var run = 0u;
        for (var j = 0u; j < SCAN_WORKGROUP; j++) {
            let v = partial[j];
            partial[j] = run;
            run += v;
        }
        atomicStore(&control[ctl_total()], run);
    }
    workgroupBarrier();
    var base = partial[li];
    for (var j = a; j < b; j++) {
        let n = atomicLoad(&control[ctl_tri_count() + j]);
        atomicStore(&control[ctl_base() + j], base);
        let fwd = ARGS_WORDS * j;
        let rev = ctl_args_rev() + ARGS_WORDS * (k - 1u - j);
        atomicStore(&control[fwd], 3u * n);
        atomicStore(&control[fwd + 1u], 1u);
        atomicStore(&control[fwd + 2u], 3u * base);
        atomicStore(&control[fwd + 3u], 0u);
        atomicStore(&control[rev], 3u * n);
        atomicStore(&control[rev + 1u], 1u);
        atomicStore(&control[rev + 2u], 3u * base);
        atomicStore(&control[rev + 3u], 0u);
        base += n;
    }
}
