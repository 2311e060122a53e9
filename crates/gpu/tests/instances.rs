//! Meshes stored once, drawn through the pass's use table (osw_gpu::uses): every use of a mesh
//! placed on the GPU draws the pixels of the same scene built with a placed copy per use
//! (`Instances::Expand`): exactly with f64 rows, within a rounding with f32 rows. A pass over
//! more nodes than its use table may hold goes on in further draws with the same pixels,
//! translucent layer included. Each mesh is uploaded once.

use glam::{DAffine3, DVec3, Vec3};
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{DrawStats, RenderOptions, Renderer};
use osw_gpu::residency::ResidencyStats;
use osw_scene::build::Instances;
use osw_scene::generators::shapes::add_box;
use osw_scene::mesh::{Mesh, Object};
use osw_scene::{BuildOptions, Camera, SceneFile};
use std::path::Path;

/// Far out, so that the scene's origin is not the world's.
const SITE: DVec3 = DVec3::new(3.0e6, 0.0, -2.0e6);

/// Two parts, each used on a 10x10 grid, turned and scaled by its place: an opaque stack of
/// crates and a translucent pane above it; and a ground of the scene's own.
fn objects() -> Vec<Object> {
    let mut stack = Mesh::default();
    for k in 0..4 {
        let o = Vec3::new(0.0, k as f32 * 0.6, 0.0);
        add_box(&mut stack, o - Vec3::new(0.5 - k as f32 * 0.1, 0.0, 0.4), o + Vec3::new(0.5 - k as f32 * 0.1, 0.55, 0.4));
    }
    let mut pane = Mesh::default();
    add_box(&mut pane, Vec3::new(-0.8, 2.6, -0.03), Vec3::new(0.8, 3.4, 0.03));
    pane.colors = vec![[90, 160, 250, 110]; pane.positions.len()];
    let mut ground = Mesh::default();
    add_box(&mut ground, Vec3::new(-2.0, -0.2, -2.0), Vec3::new(32.0, 0.0, 32.0));
    let mut objects = vec![Object::placed("ground", ground, SITE, DAffine3::IDENTITY)];
    for k in 0..100 {
        let at = DVec3::new((k % 10) as f64 * 3.1, 0.0, (k / 10) as f64 * 2.9);
        let turn = DAffine3::from_rotation_y(0.37 * k as f64) * DAffine3::from_scale(DVec3::splat(1.0 + 0.1 * (k % 3) as f64));
        for (p, mesh) in [(0, &stack), (1, &pane)] {
            let use_ = Object {
                prototype: Some(p),
                ..Object::placed(format!("part {p} use {k}"), mesh.clone(), SITE, DAffine3::from_translation(at) * turn)
            };
            objects.push(use_);
        }
    }
    objects
}

fn build(dir: &Path, instances: Instances) -> SceneFile {
    let path = dir.join(format!("{instances:?}.osw"));
    let opts = BuildOptions { instances, ..Default::default() };
    osw_scene::build_scene(objects(), "instances test", Vec::new(), &opts, &path, std::time::Instant::now(), &()).unwrap();
    SceneFile::open(&path).unwrap()
}

/// Every leaf at full detail over the grid, at 200x150; the use table capped at `max_nodes`.
fn frame(scene: &SceneFile, options: RenderOptions, max_nodes: usize) -> (Vec<u8>, DrawStats, ResidencyStats) {
    let gpu = osw_gpu::Gpu::new(None).expect("a Vulkan adapter (lavapipe: mesa-vulkan-drivers)");
    assert!(gpu.features.contains(wgpu::Features::SHADER_F64), "{}: no 64-bit floats in shaders", gpu.info.name);
    let mut r = Renderer::new(gpu, scene, 200, 150, RenderOptions { max_nodes, ..options }).unwrap();
    let camera = Camera::look_at(SITE + DVec3::new(-5.0, 7.0, -6.0), SITE + DVec3::new(14.0, 1.0, 13.0), 60.0);
    let view = r.view(&camera, 0.0);
    let lods: Vec<u32> = (0..scene.bvh_count()).map(|i| scene.node(i)).filter(|n| n.child_count == 0).map(|n| n.first_lod).collect();
    r.begin_frame();
    let drawn = r.draw(scene, &view, &lods, Pass::Color, Load::Clear).unwrap();
    (r.read_color().unwrap(), drawn, r.residency_stats())
}

/// The fraction of pixels whose RGB differs by more than `above` levels in a channel.
fn differing(a: &[u8], b: &[u8], above: u8) -> f64 {
    let off = |p: &[u8], q: &[u8]| (0..3).any(|k| p[k].abs_diff(q[k]) > above);
    a.chunks_exact(4).zip(b.chunks_exact(4)).filter(|(p, q)| off(p, q)).count() as f64 / (a.len() / 4) as f64
}

#[test]
fn uses_of_a_mesh_placed_on_the_gpu_draw_as_their_copies() {
    let dir = tempfile::tempdir().unwrap();
    let (keep, expand) = (build(dir.path(), Instances::Keep), build(dir.path(), Instances::Expand));
    assert!(keep.instances().len() >= 200 && expand.instances().is_empty());
    assert!(keep.nodes().len() == expand.nodes().len(), "the same node ids");
    let translucent = (0..keep.nodes().len() as u32).filter(|&id| keep.has_translucent(id)).count();
    assert!(translucent >= 100, "{translucent} nodes with panes");

    let exact = RenderOptions::default();
    let (image, drawn, stored_once) = frame(&keep, exact, usize::MAX);
    let (copies, drawn_copies, stored_each) = frame(&expand, exact, usize::MAX);
    assert!(image.chunks(4).any(|p| p != &image[..4]), "a blank frame tells nothing");
    assert_eq!((drawn.nodes, drawn.triangles), (drawn_copies.nodes, drawn_copies.triangles));
    assert!(image == copies, "f64 rows: {} of the pixels differ from the copies'", differing(&image, &copies, 0));

    // Each mesh once: what the copies upload, the stored-once scene uploads or draws from a
    // mesh already there.
    assert!(stored_once.upload_bytes * 4 < stored_each.upload_bytes, "{stored_once:?} against {stored_each:?}");
    assert_eq!(stored_once.upload_bytes + stored_once.shared_bytes, stored_each.upload_bytes);
    assert_eq!(stored_each.shared_bytes, 0);

    // At most 7 nodes a draw: the opaque list split in halves, the translucent one in order.
    let (parts, drawn_parts, _) = frame(&keep, exact, 7);
    assert!(drawn_parts.draws > (drawn.nodes / 7), "{} draws", drawn_parts.draws);
    assert_eq!((drawn_parts.nodes, drawn_parts.triangles), (drawn.nodes, drawn.triangles));
    assert!(parts == image, "drawn in parts: {} of the pixels differ", differing(&parts, &image, 0));

    let (single, _, _) = frame(&keep, RenderOptions { single_rows: true, ..exact }, usize::MAX);
    // Measured: 0.26% of the pixels a level or two apart (flat shading from derivatives of
    // positions a rounding apart), none more.
    let (shaded, edges) = (differing(&single, &copies, 0), differing(&single, &copies, 2));
    assert!(shaded <= 1e-2 && edges <= 1e-3, "f32 rows: {shaded} of the pixels differ from the copies', {edges} by more than 2 levels");
}
