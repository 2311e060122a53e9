//! Paper 003's interleaved sampling of the box test (sec. 3.3): with S lines, phase k counts the
//! pixels of lines y with (y + shift) mod S = k, shift = S/2 in every second span of 10 pixels.
//! The S phases partition the pixels, so their counts add up to the count of reading every
//! line, box by box: a reference that shares nothing with the shader but the definition.

use glam::DVec3;
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{BoxTest, RenderOptions, Renderer, Sampling};
use osw_scene::Camera;

#[test]
fn the_phases_of_a_sampled_box_test_add_up_to_the_whole_count() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("city.osw");
    let scene = osw_scene::generators::build_generated(osw_scene::generators::GenKind::City, 50_000, 2, &path).unwrap();
    let gpu = osw_gpu::Gpu::new(None).expect("a Vulkan adapter (lavapipe: mesa-vulkan-drivers)");
    let mut r = Renderer::new(gpu, &scene, 203, 157, RenderOptions::default()).unwrap();
    let root = scene.node(0).aabb();
    let eye = root.center().as_dvec3() + DVec3::new(0.0, 1.7 - root.center().y as f64, -0.3 * root.extent().z as f64);
    let view = r.view(&Camera::look_along(eye, DVec3::Z, 60.0), 0.0);
    // Some occluders, so that partly hidden boxes are counted too.
    let leaves: Vec<u32> = (0..scene.bvh_count()).filter(|&i| scene.node(i).child_count == 0).collect();
    let occluders: Vec<u32> = leaves.iter().step_by(3).map(|&i| scene.node(i).first_lod).collect();
    r.draw(&scene, &view, &occluders, Pass::Depth, Load::Clear).unwrap();
    let boxes: Vec<u32> = leaves.iter().copied().filter(|&i| !view.frustum.needs_no_test(&scene.node(i).aabb())).collect();
    let count = |r: &mut Renderer, (lines, first): (u32, u32)| {
        let mut out = Vec::new();
        let sampling = Sampling { lines, first };
        r.test_boxes(&view, boxes.iter().map(|&i| scene.node(i).aabb()), BoxTest::ExactCount, sampling, &mut out).unwrap();
        out.iter().map(|v| v.pixels.unwrap()).collect::<Vec<u32>>()
    };
    let whole = count(&mut r, (1, 0));
    assert!(whole.iter().filter(|&&p| p > 0).count() > 10, "too few visible boxes to tell: {whole:?}");
    for s in [2u32, 3, 10] {
        let phases: Vec<Vec<u32>> = (0..s).map(|k| count(&mut r, (s, k))).collect();
        for (b, &w) in whole.iter().enumerate() {
            let sum: u32 = phases.iter().map(|p| p[b]).sum();
            assert_eq!(sum, w, "box {} with {s} lines: phases {:?}", boxes[b], phases.iter().map(|p| p[b]).collect::<Vec<_>>());
        }
        // Each phase reads about 1/S of a large box.
        let big = (0..whole.len()).max_by_key(|&b| whole[b]).unwrap();
        for p in &phases {
            assert!(
                (p[big] as f64 - whole[big] as f64 / s as f64).abs() <= whole[big] as f64 * 0.2 + 20.0,
                "{s} lines: {} of {}",
                p[big],
                whole[big]
            );
        }
    }
}
