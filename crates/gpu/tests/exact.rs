//! RVG's floor: exact visibility draws only the triangles its item buffer found
//! visible, and only their clusters, in colour, and times each. Every pixel keeps the triangle
//! that won it, so the image of the visible ones (drawn last) must be the image of every
//! triangle drawn, pixel for pixel: a missed visible triangle, or one taken from the wrong place
//! in the pass, shows.

use glam::DVec3;
use osw_cull::cluster::ClusterTests;
use osw_gpu::draw::{Load, Pass};
use osw_gpu::exact::Reference;
use osw_gpu::renderer::{RenderOptions, Renderer};
use osw_scene::{Camera, NodeKind};

#[test]
fn drawing_only_the_visible_triangles_gives_the_whole_image() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plant.osw");
    let scene = osw_scene::generators::build_generated(osw_scene::generators::GenKind::Plant, 100_000, 3, &path).unwrap();
    let root = scene.node(0).aabb();
    let gpu = osw_gpu::Gpu::new(None).expect("a Vulkan adapter (lavapipe: mesa-vulkan-drivers)");
    // The item pass draws every triangle: so does the reference image.
    let options = RenderOptions { cluster_tests: ClusterTests::NONE, ..RenderOptions::default() };
    let mut r = Renderer::new(gpu, &scene, 192, 128, options).unwrap();
    let mut leaves: Vec<u32> =
        (0..scene.bvh_count()).map(|i| scene.node(i)).filter(|n| n.kind() == NodeKind::Leaf).map(|n| n.first_lod).collect();
    leaves.sort_unstable();
    let c = root.center().as_dvec3() + scene.origin();
    for (k, eye) in [DVec3::new(0.0, 5.0, -60.0), DVec3::new(30.0, 25.0, 10.0), DVec3::new(-8.0, 2.0, 3.0)].into_iter().enumerate() {
        let view = r.view(&Camera::look_at(c + eye, c, 60.0), 0.0);
        r.begin_frame();
        let e = r.exact(&scene, &view, 0.0, Reference::Independent).unwrap();
        let floor = r.read_color().unwrap();
        let whole = r.draw(&scene, &view, &leaves, Pass::Color, Load::Clear).unwrap();
        let image = r.read_color().unwrap();
        assert!(e.visible_draw_ms.is_some_and(|ms| ms > 0.0) && e.cluster_draw_ms.is_some_and(|ms| ms > 0.0), "camera {k}: {e:?}");
        assert!(e.cluster_triangles.is_some_and(|c| c > e.triangles), "camera {k}: {e:?}");
        assert!(e.triangles > 0 && e.triangles * 4 < whole.triangles, "camera {k}: {} of {} visible", e.triangles, whole.triangles);
        assert!(image.chunks(4).any(|p| p != &image[..4]), "camera {k}: a blank frame tells nothing");
        let differ = image.chunks(4).zip(floor.chunks(4)).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "camera {k}: {differ} pixels differ");
    }
}
