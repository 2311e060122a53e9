//! A pass whose geometry is larger than the largest vertex arena (a first frame at full detail
//! of a billion triangles overflows lavapipe's 2 GB buffers) is drawn in parts, in the same
//! order: the same pixels as one draw, also drawn over its own depth (`Pass::ColorOver`).
//! Made small here by capping the arena.

use glam::DVec3;
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{RenderOptions, Renderer};
use osw_scene::Camera;

#[test]
fn a_pass_larger_than_the_arena_is_drawn_in_parts_with_the_same_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plant.osw");
    let scene = osw_scene::generators::build_generated(osw_scene::generators::GenKind::Plant, 300_000, 5, &path).unwrap();
    let root = scene.node(0).aabb();
    // Every leaf at full detail: far more vertices than the capped arena holds.
    let lods: Vec<u32> = (0..scene.bvh_count()).map(|i| scene.node(i)).filter(|n| n.child_count == 0).map(|n| n.first_lod).collect();
    let reversed: Vec<u32> = lods.iter().rev().copied().collect();
    // From afar, and from near where boxes that share faces tie in depth at some pixels.
    for eye in [DVec3::new(0.0, 40.0, -120.0), DVec3::new(30.0, 5.0, -20.0)] {
        let c = root.center().as_dvec3() + scene.origin();
        let camera = Camera::look_at(c + eye, c, 60.0);
        let frame = |cap: u64| {
            let gpu = osw_gpu::Gpu::new(None).expect("a Vulkan adapter (lavapipe: mesa-vulkan-drivers)");
            let mut r = Renderer::new(gpu, &scene, 160, 120, RenderOptions { max_arena_bytes: cap, ..RenderOptions::default() }).unwrap();
            let view = r.view(&camera, 0.0);
            r.begin_frame();
            let drawn = r.draw(&scene, &view, &lods, Pass::Color, Load::Clear).unwrap();
            let color = r.read_color().unwrap();
            // The same set over its own depth (prev's RVG over OR's): each half's triangles and
            // the halves last to first keep the surfaces tied in depth as the colour pass had
            // them.
            r.draw(&scene, &view, &lods, Pass::Depth, Load::Clear).unwrap();
            r.draw(&scene, &view, &lods, Pass::ColorOver, Load::Clear).unwrap();
            assert!(r.read_color().unwrap() == color, "{eye}, cap {cap}: the frame drawn over its own depth differs");
            // Drawn in the other order, the tied pixels change hands.
            r.draw(&scene, &view, &reversed, Pass::Color, Load::Clear).unwrap();
            let ties = r.read_color().unwrap().chunks(4).zip(color.chunks(4)).filter(|(a, b)| a != b).count();
            (color, drawn, r.residency_stats(), ties)
        };
        let (whole, drawn_whole, stats_whole, ties) = frame(u64::MAX);
        let (parts, drawn_parts, stats_parts, _) = frame(512 << 10);
        assert_eq!(stats_whole.evictions, 0);
        assert!(stats_parts.evictions > 0, "the capped arena must evict between parts: {stats_parts:?}");
        assert_eq!((drawn_parts.nodes, drawn_parts.triangles), (drawn_whole.nodes, drawn_whole.triangles));
        assert!(whole.chunks(4).any(|p| p != &whole[..4]), "a blank frame tells nothing");
        assert!(whole == parts, "{eye}: the frame drawn in parts differs");
        // The near view checks the order of tied surfaces: some must tie.
        assert!(eye.z < -100.0 || ties > 0, "{eye}: no surfaces tie in depth, the order is not checked");
    }
}
