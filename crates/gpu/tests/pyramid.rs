//! The GPU pyramid test (depth copied into level 0, two levels reduced per dispatch, boxes
//! tested in compute) against its CPU reference, osw-cull's `HzbTester`, on the same depth
//! buffer: never hidden where the reference sees it (that would be a conservativeness failure,
//! not a tolerance), the same answer for almost every box, each remaining difference (the GPU
//! keeping a box the reference hides) named, and occluders that do hide boxes (a pyramid that answers "visible" to
//! everything would be conservative too, and useless). The odd image size pads level 0's rows
//! and leaves one level to reduce alone.

use glam::DVec3;
use osw_cull::VisibilityTester;
use osw_cull::hzb::{HzbTester, Pyramid, Read};
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{BoxTest, RenderOptions, Renderer, Sampling};
use osw_scene::Camera;

#[test]
fn the_gpu_pyramid_answers_as_the_cpu_reference() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plant.osw");
    let scene = osw_scene::generators::build_generated(osw_scene::generators::GenKind::Plant, 200_000, 3, &path).unwrap();
    let gpu = osw_gpu::Gpu::new(None).expect("a Vulkan adapter (lavapipe: mesa-vulkan-drivers)");
    let (w, h) = (300, 200);
    let mut r = Renderer::new(gpu, &scene, w, h, RenderOptions::default()).unwrap();
    let root = scene.node(0).aabb();
    let eye = root.center().as_dvec3() + DVec3::new(0.0, 1.7 - root.center().y as f64, -0.3 * root.extent().z as f64);
    let view = r.view(&Camera::look_along(eye, DVec3::Z, 60.0), 0.0);
    // Occluders: every leaf's coarsest level.
    let occluders: Vec<u32> =
        (0..scene.bvh_count()).map(|i| scene.node(i)).filter(|n| n.child_count == 0).map(|n| n.first_lod + n.lod_count - 1).collect();
    r.draw(&scene, &view, &occluders, Pass::Depth, Load::Clear).unwrap();
    r.build_pyramid();
    let boxes: Vec<u32> = (0..scene.bvh_count()).collect();
    let mut gpu_answers = Vec::new();
    r.test_boxes(&view, boxes.iter().map(|&i| scene.node(i).aabb()), BoxTest::Pyramid, Sampling::EVERY_LINE, &mut gpu_answers).unwrap();

    let cpu_pyramid = Pyramid::new(w, h, r.read_depth().unwrap());
    let mut cpu_answers = Vec::new();
    // finer 3: the GPU shader's default.
    HzbTester { nodes: scene.nodes(), pyramid: &cpu_pyramid, read: Read::at(3) }.test(&view, &boxes, &mut cpu_answers);

    let n = boxes.len();
    let hidden = |a: &[osw_cull::Visibility]| a.iter().filter(|v| !v.visible).count();
    let only_gpu_hides: Vec<u32> =
        boxes.iter().zip(gpu_answers.iter().zip(&cpu_answers)).filter(|(_, (g, c))| !g.visible && c.visible).map(|(b, _)| *b).collect();
    let only_cpu_hides: Vec<u32> =
        boxes.iter().zip(gpu_answers.iter().zip(&cpu_answers)).filter(|(_, (g, c))| g.visible && !c.visible).map(|(b, _)| *b).collect();
    let differ = only_gpu_hides.len() + only_cpu_hides.len();
    // What each remaining difference is: a box the GPU keeps (conservative) and the reference
    // hides, told by its box in camera-relative coordinates (the GPU projects its corners in
    // f32, the reference in f64: a box whose edge lands on a texel boundary may round out).
    for id in &only_cpu_hides {
        let b = scene.node(*id).aabb();
        eprintln!(
            "node {id}: kept by the GPU, hidden by the reference; camera-relative box {:?}..{:?}",
            view.relative(b.min),
            view.relative(b.max)
        );
    }
    eprintln!(
        "{n} boxes: GPU hides {}, CPU hides {}, {differ} differ, {} hidden by the GPU alone",
        hidden(&gpu_answers),
        hidden(&cpu_answers),
        only_gpu_hides.len()
    );
    assert!(hidden(&cpu_answers) > n / 10, "the occluders hide too little for the test to mean anything");
    assert!(differ * 100 <= n, "{differ} of {n} boxes answered differently");
    assert!(only_gpu_hides.is_empty(), "boxes {only_gpu_hides:?} hidden by the GPU pyramid but visible to the reference");
}
