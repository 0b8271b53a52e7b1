// Pass 3: per (level, cell) entry, look up its loops, interpolate the
// crossings (from the smaller global vertex id to the larger) and write the
// fan triangles of every loop into its level's region (and, for iso
// lighting, the interpolated gradient of every corner into out_normals).

// One output corner: the vertex and the interpolated gradient.
struct Corner {
    v: OutVertex,
    n: vec4<f32>,
}

// The crossing on local edge `e` at level t, interpolated from the smaller
// global vertex id to the larger: position, value (vertex attribute, the
// level value, or the cell's own value `cell_value` when flat) and, when
// has_gradient, the gradient.
fn edge_point(mi: MetaInfo, e: u32, t: f32, cell_value: f32) -> Corner {
    let packed = tables[params.tables.edges + mi.edge_base + e];
    let la = packed & 0xffffu;
    let lb = packed >> 16u;
    var ga = c_ids[la];
    var gb = c_ids[lb];
    var fa = c_phi[la];
    var fb = c_phi[lb];
    if ga > gb {
        let g = ga;
        ga = gb;
        gb = g;
        let f = fa;
        fa = fb;
        fb = f;
    }
    let s = (t - fa) / (fb - fa);
    let pa = grid[ga].xyz;
    let pb = grid[gb].xyz;
    var value = t + params.level_offset;
    if params.has_attribute == ATTR_VERTEX {
        value = attr[ga] + s * (attr[gb] - attr[ga]);
    } else if params.has_attribute == ATTR_CELL {
        value = cell_value;
    }
    var n = vec4<f32>(0.0);
    if params.has_gradient == 1u {
        let na = grad[ga].xyz;
        let nb = grad[gb].xyz;
        n = vec4<f32>(na + s * (nb - na), 0.0);
    }
    return Corner(OutVertex(pa + s * (pb - pa), value), n);
}

fn put(tri: u32, a: Corner, b: Corner, c: Corner) {
    if tri < params.triangle_capacity {
        out_vertices[3u * tri] = a.v;
        out_vertices[3u * tri + 1u] = b.v;
        out_vertices[3u * tri + 2u] = c.v;
        if params.has_gradient == 1u {
            out_normals[3u * tri] = a.n;
            out_normals[3u * tri + 1u] = b.n;
            out_normals[3u * tri + 2u] = c.n;
        }
    }
}

@compute @workgroup_size(64)
fn emit(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = entry_index(gid);
    if i >= params.entry_count {
        return;
    }
    let e = entries[i];
    let t = levels[e.level];
    let r = cell_variant(e, t);
    let mi = load_meta(r.y);
    let tris = variant_triangles(r.x);
    var cell_value = 0.0;
    if params.has_attribute == ATTR_CELL {
        cell_value = attr[e.slot];
    }
    var tri = atomicLoad(&control[ctl_base() + e.level]) + atomicAdd(&control[ctl_cursor() + e.level], tris);
    let l0 = tables[params.tables.variants + r.x];
    let l1 = tables[params.tables.variants + r.x + 1u];
    for (var l = l0; l < l1; l++) {
        let cs = params.tables.config + tables[params.tables.loops + 2u * l];
        let n = tables[params.tables.loops + 2u * l + 1u];
        let p0 = edge_point(mi, tables[cs], t, cell_value);
        var prev = edge_point(mi, tables[cs + 1u], t, cell_value);
        var nrm = vec3<f32>(0.0);
        let first = tri;
        for (var j = 2u; j < n; j++) {
            let cur = edge_point(mi, tables[cs + j], t, cell_value);
            put(tri, p0, prev, cur);
            nrm += cross(prev.v.pos - p0.v.pos, cur.v.pos - p0.v.pos);
            prev = cur;
            tri++;
        }
        if params.write_areas == 1u {
            let share = 0.5 * length(nrm) / f32(n - 2u);
            for (var k = first; k < tri; k++) {
                if k < params.triangle_capacity {
                    out_areas[k] = share;
                }
            }
        }
    }
}
