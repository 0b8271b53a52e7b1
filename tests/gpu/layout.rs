//! Every WGSL module parses and validates with naga, and every struct shared
//! with Rust has the same size and member offsets on both sides.

use std::mem::{offset_of, size_of};
use stratasweep::gpu::shaders;
use stratasweep::gpu::shared::*;

#[test]
fn every_wgsl_module_validates() {
    for (name, src) in shaders::all_modules() {
        if let Err(e) = shaders::validate(name, &src) {
            panic!("{e}");
        }
    }
}

#[test]
fn every_wgsl_file_is_used() {
    let mut files = Vec::new();
    for dir in ["wgsl", "wgsl/shared"] {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "wgsl") {
                files.push(std::fs::read_to_string(&p).unwrap());
            }
        }
    }
    let used = [
        shaders::TYPES,
        shaders::CELL,
        shaders::COUNT,
        shaders::SCAN,
        shaders::EMIT,
        shaders::BIN,
        shaders::DRAW,
        shaders::SLICES,
        shaders::PRE,
        shaders::PRE_SLAB,
        shaders::PRE_SURFACE,
        shaders::PRE_FRONT,
        shaders::PRESENT,
    ];
    for f in files {
        assert!(
            used.contains(&f.as_str()),
            "a .wgsl file is not part of any module"
        );
    }
}

/// A struct's name, Rust size and (member name, Rust offset) list.
type Layout = (&'static str, usize, Vec<(&'static str, usize)>);

/// The layout of each shared struct on the Rust side.
fn rust_layouts() -> Vec<Layout> {
    macro_rules! layout {
        ($t:ty, $name:literal, [$($f:ident),*]) => {
            ($name, size_of::<$t>(), vec![$((stringify!($f), offset_of!($t, $f))),*])
        };
    }
    vec![
        layout!(
            TableSections,
            "TableSections",
            [
                metas, codes, variants, loops, config, edges, face_start, face_verts
            ]
        ),
        layout!(
            EmitParams,
            "EmitParams",
            [
                entry_count,
                level_count,
                structured,
                has_attribute,
                slab,
                hex_meta,
                write_areas,
                row_width,
                hex_offsets_lo,
                hex_offsets_hi,
                tables,
                triangle_capacity,
                live_count,
                has_gradient,
                level_offset
            ]
        ),
        layout!(
            MetaInfo,
            "MetaInfo",
            [
                nv, edge_base, face_base, face_count, code_base, _pad0, _pad1, _pad2
            ]
        ),
        layout!(Entry, "Entry", [slot, level]),
        layout!(OutVertex, "OutVertex", [pos, value]),
        layout!(
            DrawArgs,
            "DrawArgs",
            [vertex_count, instance_count, first_vertex, first_instance]
        ),
        layout!(
            RenderParams,
            "RenderParams",
            [
                view_proj,
                eye,
                view_dir,
                axis,
                value_lo,
                value_hi,
                spacing_over_unit,
                perspective,
                mode,
                z_scale,
                slab,
                field_mode
            ]
        ),
    ]
}

#[test]
fn shared_structs_match_wgsl() {
    let module = shaders::validate("types.wgsl", shaders::TYPES).unwrap();
    for (name, size, members) in rust_layouts() {
        let ty = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("struct {name} missing from wgsl/shared/types.wgsl"))
            .1;
        let naga::TypeInner::Struct { members: wm, span } = &ty.inner else {
            panic!("{name} is not a struct");
        };
        assert_eq!(
            *span as usize, size,
            "{name}: WGSL size {span}, Rust {size}"
        );
        assert_eq!(wm.len(), members.len(), "{name}: member count");
        for (w, (rn, ro)) in wm.iter().zip(&members) {
            assert_eq!(w.name.as_deref(), Some(*rn), "{name}: member order");
            assert_eq!(
                w.offset as usize, *ro,
                "{name}.{rn}: WGSL offset {}, Rust {ro}",
                w.offset
            );
        }
    }
    // The constants mirrored in WGSL.
    let src = shaders::TYPES;
    for (c, v) in [
        ("META_WORDS", META_WORDS),
        ("ATTR_NONE", ATTR_NONE),
        ("ATTR_VERTEX", ATTR_VERTEX),
        ("ATTR_CELL", ATTR_CELL),
        ("ARGS_WORDS", ARGS_WORDS),
        ("WORKGROUP", WORKGROUP),
        ("SCAN_WORKGROUP", SCAN_WORKGROUP),
        (
            "MAX_META_VERTICES",
            stratasweep::metacell::MAX_META_VERTICES as u32,
        ),
    ] {
        assert!(
            src.contains(&format!("const {c}: u32 = {v}u;")),
            "constant {c} differs"
        );
    }
    assert_eq!(
        size_of::<DrawArgs>(),
        size_of::<wgpu::util::DrawIndirectArgs>()
    );
}
