//! The instanced plant (`osw build --gen plant --instanced`): bays drawn from a catalogue of
//! designs, each object a use of its design's mesh. Stored once, it keeps every invariant, and
//! at tau 0 every mode draws frames identical to frustum culling's and culls no leaf that exact
//! visibility finds; against the same plant with a placed copy per use (`--instances expand`)
//! it has the same node table and draws the same visible sets and frames (each use placed on
//! the GPU with the build's f64 arithmetic), uploading each mesh once.

mod common;
use common::*;
use osw_scene::SceneFile;
use std::path::Path;

fn build_instanced(dir: &Path, instances: &str) -> (std::path::PathBuf, serde_json::Value) {
    let out = dir.join(format!("plant-instanced-{instances}.osw"));
    osw_ok(&["build", "--gen", "plant", "--instanced", "--triangles", "400000", "--seed", "3", "--instances", instances, "-o", s(&out)]);
    let report = serde_json::from_str(&std::fs::read_to_string(out.with_extension("build.json")).unwrap()).unwrap();
    (out, report)
}

#[test]
fn every_mode_draws_the_instanced_plant_like_vfc_and_like_its_copies() {
    let d = tempfile::tempdir().unwrap();
    let ((keep, rk), (expand, re)) = (build_instanced(d.path(), "keep"), build_instanced(d.path(), "expand"));
    let n = |r: &serde_json::Value, k: &str| r[k].as_u64().unwrap_or_else(|| panic!("no {k} in {r}"));
    // The budget counts every use; the catalogue's meshes are a small share of it.
    let input = n(&rk, "input_triangles");
    assert!((input as f64 / 400_000.0 - 1.0).abs() < 0.2, "{input} triangles for a budget of 400000");
    assert!(n(&rk, "instances") * 2 > n(&rk, "objects"), "{rk}");
    assert!(n(&rk, "unique_triangles") * 4 < input, "{rk}");
    assert!(
        n(&rk, "output_bytes") * 2 < n(&re, "output_bytes"),
        "stored once {} bytes, copies {}",
        n(&rk, "output_bytes"),
        n(&re, "output_bytes")
    );
    let (a, b) = (SceneFile::open(&keep).unwrap(), SceneFile::open(&expand).unwrap());
    check_invariants(&a);
    check_invariants(&b);
    let unplaced = |f: &SceneFile| f.nodes().iter().map(|n| osw_scene::NodeRecord { instance: u32::MAX, ..*n }).collect::<Vec<_>>();
    assert!(unplaced(&a) == unplaced(&b), "node tables differ beyond their instances");

    let path = camera_path(&keep, "walk", 16);
    let run = check_conservative(d.path(), &keep, &path, "instanced");
    let copies = d.path().join("copies");
    render(&expand, &path, ("prev", "hybrid"), "0", &copies);
    let read = |r: &Path, f: &str| std::fs::read(r.join(f)).unwrap();
    assert!(read(&run.join("prev-hybrid"), "pvs.txt") == read(&copies, "pvs.txt"), "visible sets differ from the copies'");
    // A use's normals turn on the GPU in f32, a copy's on the CPU, stored rounded: a level
    // apart at a few pixels where the light rounds between them.
    let (differ, far) = (differing(&run.join("prev-hybrid"), &copies, 16), differing_by(&run.join("prev-hybrid"), &copies, 16, 1));
    assert!(differ <= 1e-3 && far == 0.0, "{differ} of the pixels differ from the copies', {far} by more than a level");
    // The same nodes drawn: the copies upload each node's vertices, the stored-once plant each
    // mesh once, and its nodes draw the rest from meshes already on the GPU.
    let summary = |r: &Path| -> serde_json::Value { serde_json::from_slice(&read(r, "summary.json")).unwrap() };
    let (sk, se) = (summary(&run.join("prev-hybrid")), summary(&copies));
    assert_eq!((n(&sk, "evictions"), n(&se, "evictions")), (0, 0));
    assert_eq!(n(&se, "upload_shared_bytes"), 0);
    let (uploaded, shared) = (n(&sk, "upload_bytes"), n(&sk, "upload_shared_bytes"));
    assert!(shared > uploaded, "{uploaded} bytes uploaded, {shared} drawn from meshes already on the GPU");
    assert_eq!(uploaded + shared, n(&se, "upload_bytes"), "the copies upload what the stored-once plant uploads or shares");
}

/// Copies written out in world coordinates, as an exporter without instancing writes them:
/// `copies` spheres (coordinates on a 2^-10 grid, as a fixed-precision export holds them) and
/// `copies` cylinders moved by whole grid steps, and a floor.
fn copies_in_world(copies: usize) -> Vec<(String, osw_scene::Mesh)> {
    use osw_scene::generators::shapes;
    let (mut sphere, mut cylinder, mut floor) = (osw_scene::Mesh::default(), osw_scene::Mesh::default(), osw_scene::Mesh::default());
    shapes::lathe(&mut sphere, glam::Vec3::ZERO, &shapes::sphere_profile(0.7, 8), 16);
    shapes::cylinder(&mut cylinder, glam::Vec3::ZERO, glam::Vec3::new(0.0, 1.5, 0.0), 0.3, 24);
    shapes::add_box(&mut floor, glam::Vec3::new(-2.0, -1.0, -2.0), glam::Vec3::new(2.5 * copies as f32, -0.8, 8.0));
    let moved = |m: &osw_scene::Mesh, at: [f32; 3]| {
        let grid = |c: f32| (c * 1024.0).round() / 1024.0;
        let positions = m.positions.iter().map(|p| [grid(p[0]) + at[0], grid(p[1]) + at[1], grid(p[2]) + at[2]]).collect();
        osw_scene::Mesh { positions, ..m.clone() }
    };
    let mut out = vec![("floor".to_string(), floor)];
    for k in 0..copies {
        let x = 2.5 * k as f32;
        out.push((format!("sphere {k}"), moved(&sphere, [x, 0.0, 0.0])));
        out.push((format!("pillar {k}"), moved(&cylinder, [x + 0.75, -0.75, 3.0])));
    }
    out
}

fn write_obj(path: &Path, objects: &[(String, osw_scene::Mesh)]) {
    use std::fmt::Write;
    let (mut text, mut base) = (String::new(), 1);
    for (name, m) in objects {
        writeln!(text, "g {name}").unwrap();
        // As f64: the f32 values to the last digit.
        m.positions.iter().for_each(|p| writeln!(text, "v {} {} {}", p[0] as f64, p[1] as f64, p[2] as f64).unwrap());
        m.indices.chunks_exact(3).for_each(|t| writeln!(text, "f {} {} {}", t[0] + base, t[1] + base, t[2] + base).unwrap());
        base += m.positions.len() as u32;
    }
    std::fs::write(path, text).unwrap();
}

/// A glTF of one mesh per object, every node without a transform (a glTF exported without
/// reusing its meshes).
fn write_gltf(path: &Path, objects: &[(String, osw_scene::Mesh)]) {
    let (mut bin, mut views, mut accessors) = (Vec::new(), Vec::new(), Vec::new());
    let meshes: Vec<serde_json::Value> =
        objects.iter().map(|(_, m)| serde_json::json!({"primitives": [push_mesh(&mut bin, &mut views, &mut accessors, m)]})).collect();
    let nodes: Vec<serde_json::Value> =
        objects.iter().enumerate().map(|(k, (name, _))| serde_json::json!({"name": name, "mesh": k})).collect();
    let doc = serde_json::json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": (0..objects.len()).collect::<Vec<_>>()}],
        "nodes": nodes, "meshes": meshes, "accessors": accessors, "bufferViews": views});
    write_glb(path, doc, &bin);
}

#[test]
fn copies_the_input_does_not_name_are_found_and_draw_as_the_copies() {
    let d = tempfile::tempdir().unwrap();
    let objects = copies_in_world(12);
    for format in ["obj", "glb"] {
        let input = d.path().join(format!("copies.{format}"));
        match format {
            "obj" => write_obj(&input, &objects),
            _ => write_gltf(&input, &objects),
        }
        let build = |instances: &str| {
            let out = d.path().join(format!("copies-{format}-{instances}.osw"));
            osw_ok(&["build", s(&input), "--instances", instances, "-o", s(&out)]);
            let report: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(out.with_extension("build.json")).unwrap()).unwrap();
            (out, report)
        };
        let ((keep, rk), (expand, re)) = (build("keep"), build("expand"));
        // Two meshes of 12 copies each: the first of each stays as it came, the other 11 are
        // its uses.
        assert_eq!(rk["found_repeats"], 22, "{format}: {rk}");
        assert_eq!(re["found_repeats"], 22, "{format}: {re}");
        assert!(rk["output_bytes"].as_u64().unwrap() < re["output_bytes"].as_u64().unwrap(), "{rk}");
        let (a, b) = (SceneFile::open(&keep).unwrap(), SceneFile::open(&expand).unwrap());
        check_invariants(&a);
        let unplaced = |f: &SceneFile| f.nodes().iter().map(|n| osw_scene::NodeRecord { instance: u32::MAX, ..*n }).collect::<Vec<_>>();
        assert!(unplaced(&a) == unplaced(&b), "{format}: node tables differ beyond their instances");
        let path = camera_path(&keep, "orbit", 12);
        let run = check_conservative(d.path(), &keep, &path, format);
        let copies = d.path().join(format!("copies-{format}"));
        render(&expand, &path, ("prev", "hybrid"), "0", &copies);
        let read = |r: &Path, f: &str| std::fs::read(r.join(f)).unwrap();
        assert!(read(&run.join("prev-hybrid"), "pvs.txt") == read(&copies, "pvs.txt"), "{format}: visible sets differ from the copies'");
        let differ = differing(&run.join("prev-hybrid"), &copies, 12);
        assert!(differ == 0.0, "{format}: {differ} of the pixels differ from the copies'");
    }
}
