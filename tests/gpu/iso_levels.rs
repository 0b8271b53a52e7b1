//! The viewer caches isosurfaces one isovalue at a time: changing one of
//! three isovalues sweeps and emits that level only (counted by the
//! scene's levels-swept counter and the compute dispatch counter), and the
//! frame then equals `render`'s, which builds all three levels at once.

use crate::support;

use std::sync::Arc;

use stratasweep::generate::warped;
use stratasweep::gpu::render::{Mode, RenderOptions, Renderer};
use stratasweep::gpu::view::scene::Scene;
use stratasweep::structures::{Structure, StructureChoice};

#[test]
fn changing_one_of_three_isovalues_sweeps_one_level() {
    let Some(ctx) = support::gpu("changing_one_of_three_isovalues_sweeps_one_level") else {
        return;
    };
    let g = warped([12, 10, 8], 2);
    let s = Arc::new(Structure::build(&g, StructureChoice::Auto).unwrap());
    let mut o = RenderOptions {
        mode: Mode::Iso,
        iso: vec![0.2, 0.5, 0.8],
        size: (64, 48),
        ..Default::default()
    };
    let mut sc = Scene::new(ctx, Arc::new(g.clone()), s.clone(), o.clone(), 1.0, false).unwrap();
    let d0 = sc.dispatches();
    assert!(
        d0 > 0 && d0.is_multiple_of(3),
        "{d0} dispatches for three levels"
    );
    let per_level = d0 / 3;
    o.iso = vec![0.2, 0.6, 0.8];
    sc.options.iso = o.iso.clone();
    sc.request().unwrap();
    assert!(sc.building(), "the new isovalue is built on the worker");
    assert!(sc.poll(true).unwrap());
    assert_eq!(sc.stats.resweeps, 1);
    assert_eq!(sc.stats.levels_swept, 1, "one level swept, not three");
    assert_eq!(sc.dispatches() - d0, per_level);
    // Back to an isovalue set whose levels are all cached except the dropped one.
    let img = sc.image(1).unwrap();
    let want = Renderer::new(ctx).unwrap().render(&g, &s, &o).unwrap();
    let (a, b) = (img.rgba8(), want.rgba8());
    let mad = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (*x as f64 - *y as f64).abs())
        .sum::<f64>()
        / a.len() as f64;
    assert!(mad <= 0.5, "mean difference to render {mad}");
    assert!(
        img.premultiplied.iter().any(|p| p[3] > 0.5),
        "no isosurface drawn"
    );
}
