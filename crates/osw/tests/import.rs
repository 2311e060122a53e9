//! Real models far from the origin: a glTF whose root node is translated by 1e7 or 1e9 (site
//! coordinates, as georeferenced plant, BIM and city models are written), and a PLY with
//! `double` coordinates, each against the same model at the origin (the reference: nothing
//! shared but the model). At 1e7 the scene's tables and blocks and the frames of a walk are
//! identical; at 1e9 the frames differ in at most 1% of pixels.

mod common;
use common::*;
use osw_render::compare::image_error;
use osw_render::output::{frame_path, read_png};
use osw_scene::SceneFile;
use osw_scene::mesh::Object;
use serde_json::json;
use std::path::Path;

/// The 100K-triangle plant's objects, in world coordinates at the origin.
fn plant() -> Vec<Object> {
    osw_scene::generators::generate(osw_scene::generators::GenKind::Plant, 100_000, 1).objects
}

/// A GLB with one mesh and one node per object, all children of one root node translated by
/// `root` (written as JSON numbers, which carry f64).
fn write_glb(path: &Path, objects: &[Object], root: [f64; 3]) {
    let (mut bin, mut views, mut accessors, mut meshes, mut nodes) = (Vec::<u8>::new(), vec![], vec![], vec![], vec![]);
    nodes.push(json!({"translation": root, "children": (1..=objects.len()).collect::<Vec<_>>()}));
    for (k, o) in objects.iter().enumerate() {
        let b = o.mesh.bounds();
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": o.mesh.positions.len() * 12}));
        o.mesh.positions.iter().flatten().for_each(|c| bin.extend(c.to_le_bytes()));
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": o.mesh.indices.len() * 4}));
        o.mesh.indices.iter().for_each(|i| bin.extend(i.to_le_bytes()));
        accessors.push(json!({"bufferView": 2 * k, "componentType": 5126, "count": o.mesh.positions.len(), "type": "VEC3",
            "min": b.min.to_array(), "max": b.max.to_array()}));
        accessors.push(json!({"bufferView": 2 * k + 1, "componentType": 5125, "count": o.mesh.indices.len(), "type": "SCALAR"}));
        meshes.push(json!({"primitives": [{"attributes": {"POSITION": 2 * k}, "indices": 2 * k + 1}]}));
        nodes.push(json!({"name": o.name, "mesh": k}));
    }
    let doc = json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes, "meshes": meshes,
        "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": bin.len()}]});
    let mut text = serde_json::to_vec(&doc).unwrap();
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let mut glb = Vec::new();
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + text.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((text.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&text);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&bin);
    std::fs::write(path, glb).unwrap();
}

/// A binary PLY with double coordinates: all objects as one mesh, moved by `shift` in f64.
fn write_ply_double(path: &Path, objects: &[Object], shift: [f64; 3]) {
    let verts: usize = objects.iter().map(|o| o.mesh.positions.len()).sum();
    let faces: usize = objects.iter().map(|o| o.mesh.triangle_count()).sum();
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {verts}\nproperty double x\nproperty double y\nproperty double z\nelement face {faces}\nproperty list uchar uint vertex_indices\nend_header\n"
    )
    .into_bytes();
    for p in objects.iter().flat_map(|o| &o.mesh.positions) {
        (0..3).for_each(|k| b.extend((p[k] as f64 + shift[k]).to_le_bytes()));
    }
    let mut base = 0u32;
    for o in objects {
        for t in o.mesh.indices.chunks_exact(3) {
            b.push(3);
            t.iter().for_each(|i| b.extend((base + i).to_le_bytes()));
        }
        base += o.mesh.positions.len() as u32;
    }
    std::fs::write(path, b).unwrap();
}

fn build(input: &Path) -> (SceneFile, serde_json::Value) {
    let scene = input.with_extension("osw");
    osw_ok(&["build", s(input), "-o", s(&scene)]);
    let report = serde_json::from_str(&std::fs::read_to_string(scene.with_extension("build.json")).unwrap()).unwrap();
    (SceneFile::open(&scene).unwrap(), report)
}

/// Renders an 8-frame walk through `scene` with the switch's algorithm at tau 0.
fn walk(scene: &SceneFile, out: &Path) {
    let p = camera_path(scene.path(), "walk", 8);
    render(scene.path(), &p, ("prev", "hybrid"), "0", out);
}

/// The largest fraction of differing pixels over the frames of two runs.
fn differing(a: &Path, b: &Path) -> f64 {
    (0..8u64)
        .map(|i| {
            let ((_, _, pa), (_, _, pb)) = (read_png(&frame_path(a, i)).unwrap(), read_png(&frame_path(b, i)).unwrap());
            image_error(&pa, &pb).differing_fraction
        })
        .fold(0.0, f64::max)
}

/// `far` was built from the model of `near` moved by whole units `shift`: same tables, same
/// blocks, nothing dropped, the origin moved by exactly `shift`.
fn assert_same_scene(near: &(SceneFile, serde_json::Value), far: &(SceneFile, serde_json::Value), shift: [f64; 3]) {
    assert_eq!(far.0.origin() - near.0.origin(), glam::DVec3::from_array(shift));
    assert!(near.0.nodes() == far.0.nodes(), "node tables differ {shift:?} from the origin");
    assert!(near.0.blocks() == far.0.blocks(), "geometry blocks differ {shift:?} from the origin");
    for key in ["chunks", "loose_splits", "degenerate_triangles_dropped", "input_triangles", "stored_triangles"] {
        assert_eq!(near.1[key], far.1[key], "{key}");
    }
}

#[test]
fn a_gltf_whose_root_is_translated_far_builds_and_renders_as_at_the_origin() {
    let d = tempfile::tempdir().unwrap();
    let objects = plant();
    let models = [("near", [0.0; 3]), ("far7", [1e7, -1e7, 1e7]), ("far9", [1e9, 1e9, -1e9])];
    let mut scenes = Vec::new();
    for (name, root) in models {
        let glb = d.path().join(format!("{name}.glb"));
        write_glb(&glb, &objects, root);
        scenes.push(build(&glb));
        walk(&scenes.last().unwrap().0, &d.path().join(name));
    }
    assert_same_scene(&scenes[0], &scenes[1], models[1].1);
    for i in 0..8 {
        let f = |n: &str| std::fs::read(frame_path(&d.path().join(n), i)).unwrap();
        assert!(f("near") == f("far7"), "frame {i} differs 1e7 units from the origin");
    }
    // At 1e9, f64's spacing (2^-23) moves small coordinates by up to one f32 step.
    assert_eq!(scenes[2].0.header().leaf_triangles, scenes[0].0.header().leaf_triangles);
    let diff = differing(&d.path().join("near"), &d.path().join("far9"));
    assert!(diff <= 0.01, "{:.3}% of pixels differ 1e9 units from the origin", diff * 100.0);
}

#[test]
fn a_ply_with_double_coordinates_far_from_the_origin_builds_and_renders_as_at_the_origin() {
    let d = tempfile::tempdir().unwrap();
    let objects = plant();
    let shift = [-1e7, 1e7, 1e7];
    let (near, far) = (d.path().join("near.ply"), d.path().join("far.ply"));
    write_ply_double(&near, &objects, [0.0; 3]);
    write_ply_double(&far, &objects, shift);
    let (a, b) = (build(&near), build(&far));
    assert_same_scene(&a, &b, shift);
    walk(&a.0, &d.path().join("near"));
    walk(&b.0, &d.path().join("far"));
    assert_eq!(differing(&d.path().join("near"), &d.path().join("far")), 0.0, "frames differ 1e7 units from the origin");
}
