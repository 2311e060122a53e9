//! HC's pass where a region comes into view (a turn from open ground to the plant, so that OR
//! drew almost nothing of the new view): with the new LODs taken as occluders while it
//! traverses (`HcOptions::new_occluders_min`, from one at a time, so that the path runs on a small scene) it
//! keeps every leaf exact visibility (the item buffer) sees, keeps no more than without them,
//! and tests fewer boxes.

use glam::DVec3;
use osw_gpu::draw::Load;
use osw_gpu::exact::Reference;
use osw_gpu::renderer::{RenderOptions, Renderer};
use osw_render::pass::{self, HcOptions};
use osw_scene::{Camera, NodeId};

#[test]
fn new_occluders_keep_every_visible_leaf_and_save_tests() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plant.osw");
    let scene = osw_scene::generators::build_generated(osw_scene::generators::GenKind::Plant, 200_000, 3, &path).unwrap();
    let gpu = osw_gpu::Gpu::new(None).expect("a Vulkan adapter (lavapipe: mesa-vulkan-drivers)");
    let mut r = Renderer::new(gpu, &scene, 256, 256, RenderOptions::default()).unwrap();
    let root = scene.node(0).aabb();
    let (c, e) = (root.center().as_dvec3(), root.extent().as_dvec3());
    let eye = c + DVec3::new(0.9 * e.x, 0.1 * e.y, 0.0);
    // V(i-1): what is visible from beside the plant, looking away from it.
    let before = r.view(&Camera::look_at(eye, eye + DVec3::X, 60.0), 0.0);
    r.begin_frame();
    let mut previous = Vec::new();
    pass::hc(&mut r, &scene, &before, HcOptions::default(), &[], &mut Vec::new(), &mut previous).unwrap();
    assert!(!previous.is_empty(), "nothing visible before the turn: OR would draw nothing");
    // Frame i turns to the plant: OR draws V(i-1) for it, then HC.
    let after = r.view(&Camera::look_at(eye, c + DVec3::new(0.0, 0.0, e.z), 60.0), 0.0);
    let mut run = |min: usize| {
        r.begin_frame();
        pass::or(&mut r, &scene, &after, pass::Occluders { ids: &previous, tau: 0.0, load: Load::Clear }, &mut Vec::new()).unwrap();
        let mut pvs = Vec::new();
        let stats = pass::hc(
            &mut r,
            &scene,
            &after,
            HcOptions { new_occluders_min: min, ..HcOptions::default() },
            &previous,
            &mut Vec::new(),
            &mut pvs,
        )
        .unwrap()
        .stats;
        (pvs, stats)
    };
    let (with, with_stats) = run(1);
    let (without, without_stats) = run(usize::MAX);
    r.begin_frame();
    let exact = r.exact(&scene, &after, 0.0, Reference::Independent).unwrap();
    let leaves = |pvs: &[NodeId]| -> Vec<NodeId> {
        let mut l: Vec<NodeId> = pvs.iter().map(|&id| scene.node(id).parent).collect();
        l.sort_unstable();
        l
    };
    let (lw, lo) = (leaves(&with), leaves(&without));
    let missed: Vec<&NodeId> = exact.leaves.iter().filter(|l| lw.binary_search(l).is_err()).collect();
    assert!(missed.is_empty(), "visible leaves culled with new occluders: {missed:?}");
    assert!(exact.leaves.iter().all(|l| lo.binary_search(l).is_ok()), "visible leaves culled without new occluders");
    assert!(!exact.leaves.is_empty() && lw.len() <= lo.len(), "with {} leaves, without {}", lw.len(), lo.len());
    assert!(
        with_stats.tests < without_stats.tests,
        "new occluders save no tests: {} with, {} without",
        with_stats.tests,
        without_stats.tests
    );
    eprintln!(
        "leaves: {} exact, {} with, {} without; tests {} with, {} without",
        exact.leaves.len(),
        lw.len(),
        lo.len(),
        with_stats.tests,
        without_stats.tests
    );
}
