//! Real models far from the origin: a glTF whose root node is translated by 1e7 or 1e9 (site
//! coordinates, as georeferenced plant, BIM and city models are written) above nested node
//! transforms with rotations, non-uniform scales and fractional offsets, and a PLY with
//! `double` coordinates, each against the same model at the origin (the reference: nothing
//! shared but the model). The scene's tables and blocks and the frames of a walk are
//! identical.

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

/// A GLB with one mesh and one node per object under two nested nodes (a rotation about the
/// vertical and a fractional offset; a non-uniform scale, another rotation and offset), all
/// under one root node translated by `root` (written as JSON numbers, which carry f64). Each
/// object's node has a fractional offset of its own.
fn write_nested_glb(path: &Path, objects: &[Object], root: [f64; 3]) {
    let (mut bin, mut views, mut accessors, mut meshes, mut nodes) = (Vec::<u8>::new(), vec![], vec![], vec![], vec![]);
    let (r1, r2) = ((0.37f64 / 2.0).sin_cos(), (-0.3691f64 / 2.0).sin_cos());
    nodes.push(json!({"translation": root, "children": [1]}));
    nodes.push(json!({"rotation": [0.0, r1.0, 0.0, r1.1], "translation": [0.123_456_789, 0.0, -3.333_333_333], "children": [2]}));
    nodes.push(json!({"rotation": [0.0, r2.0, 0.0, r2.1], "scale": [1.000_3, 0.999_7, 1.000_01], "translation": [-1.718_281_828, 0.25, 0.314_159_265],
        "children": (3..3 + objects.len()).collect::<Vec<_>>()}));
    for (k, o) in objects.iter().enumerate() {
        meshes.push(json!({"primitives": [push_mesh(&mut bin, &mut views, &mut accessors, &o.mesh)]}));
        nodes.push(json!({"name": o.name, "mesh": k, "translation": [k as f64 * 1e-7, 0.0, -(k as f64) * 3.1e-8]}));
    }
    let doc = json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes, "meshes": meshes,
        "accessors": accessors, "bufferViews": views});
    write_glb(path, doc, &bin);
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
        write_nested_glb(&glb, &objects, root);
        scenes.push(build(&glb));
        walk(&scenes.last().unwrap().0, &d.path().join(name));
    }
    for (k, (far, shift)) in models.iter().enumerate().skip(1) {
        assert_same_scene(&scenes[0], &scenes[k], *shift);
        for i in 0..8 {
            let f = |n: &str| std::fs::read(frame_path(&d.path().join(n), i)).unwrap();
            assert!(f("near") == f(far), "frame {i} differs {shift:?} from the origin");
        }
    }
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
    assert_eq!(differing(&d.path().join("near"), &d.path().join("far"), 8), 0.0, "frames differ 1e7 units from the origin");
}

fn fixture(rel: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(rel)
}

/// Every vertex of every object in world coordinates (placements applied in f64), and the
/// triangle count.
fn world_vertices(input: &Path) -> (Vec<glam::DVec3>, usize) {
    let imported = osw_scene::import::read(input).unwrap_or_else(|e| panic!("{e}"));
    let tris = imported.objects.iter().map(|o| o.mesh.triangle_count()).sum();
    let v = imported.objects.iter().flat_map(|o| o.mesh.positions.iter().map(|p| o.world(*p))).collect();
    (v, tris)
}

/// The GLB at `path` with its JSON chunk changed by `edit`.
fn edit_glb(path: &Path, edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let b = std::fs::read(path).unwrap();
    let n = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    let mut doc: serde_json::Value = serde_json::from_slice(&b[20..20 + n]).unwrap();
    edit(&mut doc);
    let mut text = serde_json::to_vec(&doc).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let rest = &b[20 + n..];
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((20 + text.len() + rest.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend(rest);
    out
}

/// The quantization step, in world units, of each vertex of `input`: its stored coordinates'
/// grid (integers; normalized 16-bit integers, multiples of 1/65535; floats with a 14-bit
/// mantissa, as gltfpack -vpf writes them) scaled by the object's placement.
fn steps(input: &Path) -> Vec<f64> {
    let imported = osw_scene::import::read(input).unwrap();
    let mut out = Vec::new();
    for o in &imported.objects {
        let c: Vec<f64> = o.mesh.positions.iter().flatten().map(|&c| c as f64).collect();
        let on_grid = |unit: f64| c.iter().all(|&x| ((x / unit).round() * unit - x).abs() <= 1e-6 * unit.max(x.abs()));
        let scale = [o.placement.matrix3.x_axis, o.placement.matrix3.y_axis, o.placement.matrix3.z_axis].map(|a| a.length());
        let unit = if on_grid(1.0) {
            1.0
        } else if on_grid(1.0 / 65535.0) {
            1.0 / 65535.0
        } else {
            c.iter().fold(0.0f64, |m, x| m.max(x.abs())) / f64::from(1 << 13)
        };
        out.extend(std::iter::repeat_n(unit * scale.iter().fold(0.0f64, |a, b| a.max(*b)), o.mesh.positions.len()));
    }
    out
}

/// gltfpack's output (scripts/make-fixtures.sh: quantized integer and normalized positions,
/// meshopt-compressed with and without the exponential filter, instanced) reads as its float
/// source: the same triangles, every vertex within one quantization step (of its file) of a
/// vertex of the source.
#[test]
fn gltfpack_output_reads_as_its_source() {
    let (src, src_tris) = world_vertices(&fixture("gltf/source.gltf"));
    for f in ["packed.glb", "packed-cc.glb", "packed-mi.glb", "packed-vpn-cc.glb", "packed-vpf-cc.glb"] {
        let path = fixture(&format!("gltf/{f}"));
        let (v, tris) = world_vertices(&path);
        assert_eq!(tris, src_tris, "{f}");
        let steps = steps(&path);
        let worst = steps.iter().fold(0.0f64, |a, b| a.max(*b));
        assert!(worst < 0.05, "{f}: a step of {worst} is not a 14-bit quantization of this model");
        for (p, step) in v.iter().zip(&steps) {
            let d = src.iter().map(|q| (*p - *q).abs().max_element()).fold(f64::INFINITY, f64::min);
            assert!(d <= *step, "{f}: vertex {p} lies {d} from the source's nearest, more than its step {step}");
        }
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("s.osw");
        osw_ok(&["build", s(&path), "-o", s(&out)]);
        check_invariants(&SceneFile::open(&out).unwrap());
    }
    let instanced = osw_scene::import::read(&fixture("gltf/packed-mi.glb")).unwrap();
    assert!(instanced.objects.iter().filter(|o| o.name.contains("instance")).count() >= 4, "EXT_mesh_gpu_instancing was not expanded");
}

#[test]
fn draco_corrupt_streams_and_out_of_buffer_accessors_are_named() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("s.osw");
    osw_err(&["build", s(&fixture("gltf/draco.glb")), "-o", s(&out)], "KHR_draco_mesh_compression");
    type Edit = Box<dyn FnOnce(&mut serde_json::Value)>;
    let cases: [(&str, &str, Edit, &str); 4] = [
        (
            "packed-cc.glb",
            "truncated.glb",
            Box::new(|j| {
                let m = &mut j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"];
                m["byteLength"] = json!(m["byteLength"].as_u64().unwrap() / 2);
            }),
            "corrupt or truncated",
        ),
        (
            "packed-cc.glb",
            "past.glb",
            Box::new(|j| j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["byteOffset"] = json!(1u64 << 40)),
            "reach past",
        ),
        ("packed.glb", "accessor.glb", Box::new(|j| j["accessors"][0]["count"] = json!(1_000_000)), "reaches past the end of its buffer"),
        (
            "packed.glb",
            "required.glb",
            Box::new(|j| j["extensionsRequired"] = json!(["KHR_mesh_quantization", "EXT_from_the_future"])),
            "EXT_from_the_future",
        ),
    ];
    for (from, name, edit, needle) in cases {
        let p = d.path().join(name);
        std::fs::write(&p, edit_glb(&fixture(&format!("gltf/{from}")), edit)).unwrap();
        let err = osw_err(&["build", s(&p), "-o", s(&out)], needle);
        assert!(err.contains(name), "{err}");
        assert!(!out.exists());
    }
}

/// A glTF of a quad as a list, a strip, a fan and a sparse accessor over a zero base: all four
/// give the same triangles and positions.
#[test]
fn strips_fans_and_sparse_accessors_read_as_the_list() {
    let d = tempfile::tempdir().unwrap();
    let quad = [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let bin: Vec<u8> = quad.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    let write = |name: &str, mode: u32, order: &[u32], sparse: bool| {
        let mut b = bin.clone();
        let idx_at = b.len();
        order.iter().for_each(|i| b.extend((*i as u16).to_le_bytes()));
        while !b.len().is_multiple_of(4) {
            b.push(0);
        }
        let sp_at = b.len();
        [1u8, 2, 3, 0].iter().for_each(|i| b.push(*i));
        let pos = if sparse {
            // Base: no view (zeros); vertices 1, 2, 3 substituted from the first view.
            json!({"componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0],
                "sparse": {"count": 3, "indices": {"bufferView": 2, "componentType": 5121}, "values": {"bufferView": 0, "byteOffset": 12}}})
        } else {
            json!({"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]})
        };
        let uri = format!("data:application/octet-stream;base64,{}", base64::encode(&b));
        let doc = json!({"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": mode}]}],
            "accessors": [pos, {"bufferView": 1, "componentType": 5123, "count": order.len(), "type": "SCALAR"}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": idx_at, "byteLength": order.len() * 2},
                {"buffer": 0, "byteOffset": sp_at, "byteLength": 3}],
            "buffers": [{"byteLength": b.len(), "uri": uri}]});
        let p = d.path().join(name);
        std::fs::write(&p, serde_json::to_vec(&doc).unwrap()).unwrap();
        world_triangles(&p)
    };
    let list = write("list.gltf", 4, &[0, 1, 2, 0, 2, 3], false);
    assert_eq!(list.len(), 2);
    // Strip 1 2 0 3: triangles (1, 2, 0) and (2, 3, 0), the list's two with their winding.
    assert_eq!(write("strip.gltf", 5, &[1, 2, 0, 3], false), list);
    assert_eq!(write("fan.gltf", 6, &[0, 1, 2, 3], false), list);
    assert_eq!(write("sparse.gltf", 4, &[0, 1, 2, 0, 2, 3], true), list);
}

type Tri = [[f32; 3]; 3];

/// Triangles as corner positions, each rotated to start at its least corner, sorted.
fn canon(mut t: Vec<Tri>) -> Vec<Tri> {
    for tri in &mut t {
        let k = (0..3).min_by(|&a, &b| tri[a].partial_cmp(&tri[b]).unwrap()).unwrap();
        tri.rotate_left(k);
    }
    t.sort_by(|a, b| a.partial_cmp(b).unwrap());
    t
}

fn world_triangles(input: &Path) -> Vec<Tri> {
    let imported = osw_scene::import::read(input).unwrap_or_else(|e| panic!("{e}"));
    let mut t = Vec::new();
    for o in &imported.objects {
        let w = |i: u32| o.world(o.mesh.positions[i as usize]).as_vec3().to_array();
        t.extend(o.mesh.indices.chunks_exact(3).map(|c| [w(c[0]), w(c[1]), w(c[2])]));
    }
    canon(t)
}

/// The OBJ fixture (objects, a group, polygons, v/vt/vn faces, negative indices, mtllib) reads
/// as the same triangles written by hand as an ASCII PLY: another reader, another format.
#[test]
fn obj_reads_as_the_same_model_in_ply() {
    let d = tempfile::tempdir().unwrap();
    let v = [
        [0.0, 0.0, 0.0],
        [4.0, 0.0, 0.0],
        [4.0, 0.0, 2.0],
        [0.0, 0.0, 2.0],
        [1.0, 0.5, 1.0],
        [1.5, 0.5, 1.0],
        [1.7, 1.0, 1.0],
        [1.25, 1.4, 1.0],
        [0.8, 1.0, 1.0],
        [1.0, 0.5, 1.5],
        [1.5, 0.5, 1.5],
    ];
    let faces = ["4 0 3 2 1", "5 4 5 6 7 8", "4 4 5 10 9"];
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        v.len(),
        faces.len()
    );
    v.iter().for_each(|p: &[f64; 3]| ply += &format!("{} {} {}\n", p[0], p[1], p[2]));
    faces.iter().for_each(|f| ply += &format!("{f}\n"));
    let p = d.path().join("model.ply");
    std::fs::write(&p, ply).unwrap();
    let obj = fixture("obj/model.obj");
    assert_eq!(world_triangles(&obj), world_triangles(&p));
    let objects = osw_scene::import::read(&obj).unwrap().objects;
    let names: Vec<&str> = objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["slab", "tank", "tank_side"]);
    let out = d.path().join("obj.osw");
    osw_ok(&["build", s(&obj), "-o", s(&out)]);
    assert_eq!(SceneFile::open(&out).unwrap().header().leaf_triangles, 2 + 3 + 2);
}

#[test]
fn bad_obj_names_the_file_and_the_fault() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("s.osw");
    let p = d.path().join("range.obj");
    std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
    let err = osw_err(&["build", s(&p), "-o", s(&out)], "index out of range");
    assert!(err.contains("range.obj"), "{err}");
    let p = d.path().join("nomtl.obj");
    std::fs::write(&p, "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let err = osw_err(&["build", s(&p), "-o", s(&out)], "missing.mtl");
    assert!(err.contains("nomtl.obj") && err.contains("No such file"), "{err}");
    assert!(!out.exists());
}

/// Pixels of a frame drawn in `c` under some light (flat shading scales a colour by 0.35 to 1).
fn shaded_pixels(rgba: &[u8], c: [u8; 3]) -> usize {
    rgba.chunks_exact(4)
        .filter(|p| {
            let k = p[0] as f64 / c[0] as f64;
            (0.3..=1.01).contains(&k) && (1..3).all(|i| (p[i] as f64 - k * c[i] as f64).abs() <= 3.0)
        })
        .count()
}

/// A walk around the coloured model shows its material colours (linear baseColorFactor, as
/// sRGB bytes); built with `--colors hashed` it does not. The build reports objects without
/// a colour.
#[test]
fn a_coloured_model_renders_in_its_colours() {
    let d = tempfile::tempdir().unwrap();
    let model = fixture("gltf/packed-cc.glb");
    // sRGB of the source's baseColorFactor (0.8, 0.2, 0.1), (0.2, 0.5, 0.9), (0.9, 0.8, 0.2).
    let paints = [[231u8, 124, 89], [124, 188, 243], [243, 231, 124]];
    let mut counts = Vec::new();
    for colors in ["model", "hashed"] {
        let scene = d.path().join(format!("{colors}.osw"));
        let out = osw_ok(&["build", s(&model), "--colors", colors, "-o", s(&scene)]);
        let uncoloured = if colors == "model" { 0 } else { 8 };
        assert!(out.contains(&format!("colours: {uncoloured} of 8 objects have none")), "{out}");
        let path = scene.with_extension("csv");
        osw_ok(&["path", "--scene", s(&scene), "--kind", "orbit", "--frames", "4", "-o", s(&path)]);
        let run = d.path().join(colors);
        render(&scene, &path, ("prev", "hybrid"), "0", &run);
        let (_, _, rgba) = read_png(&frame_path(&run, 1)).unwrap();
        counts.push(paints.map(|c| shaded_pixels(&rgba, c)));
    }
    let pixels = 256 * 256;
    for (k, c) in paints.iter().enumerate() {
        assert!(counts[0][k] > pixels / 200, "colour {c:?}: {} pixels in the model's colours", counts[0][k]);
        assert!(counts[1][k] < counts[0][k] / 10, "colour {c:?}: {} pixels with --colors hashed", counts[1][k]);
    }
}

/// The build counts a model's repeats: the Khronos engine uses 14 of its 29 meshes in 52 nodes.
/// The reference is the same file with each mesh kept in its first node only (the others'
/// `mesh` removed), which has no repeats: its triangles after clean-up are the unique ones.
#[test]
fn the_engines_repeated_meshes_are_counted_once() {
    let Some(engine) = real_model("the_engines_repeated_meshes_are_counted_once", "2CylinderEngine.glb") else { return };
    let d = tempfile::tempdir().unwrap();
    let (mut uses, mut repeated) = (std::collections::HashMap::new(), (0, 0));
    let once = edit_glb(&engine, |doc| {
        for node in doc["nodes"].as_array_mut().unwrap() {
            if let Some(m) = node.get("mesh").and_then(|m| m.as_u64()) {
                *uses.entry(m).or_insert(0) += 1;
                if uses[&m] > 1 {
                    node.as_object_mut().unwrap().remove("mesh");
                }
            }
        }
    });
    for &n in uses.values().filter(|&&n| n > 1) {
        repeated = (repeated.0 + 1, repeated.1 + n);
    }
    assert_eq!(repeated, (14, 52), "the engine's meshes used more than once, and their uses");
    let once_path = d.path().join("once.glb");
    std::fs::write(&once_path, once).unwrap();
    let full_path = d.path().join("engine.glb");
    std::fs::copy(&engine, &full_path).unwrap();
    let ((_, full), (_, once)) = (build(&full_path), build(&once_path));
    let n = |r: &serde_json::Value, k: &str| r[k].as_u64().unwrap_or_else(|| panic!("no {k} in {r}"));
    assert_eq!(n(&full, "input_triangles"), 121_496);
    assert_eq!(n(&full, "instances"), 52);
    assert_eq!(n(&once, "instances"), 0);
    assert_eq!(n(&full, "unique_triangles"), n(&once, "input_triangles") - n(&once, "degenerate_triangles_dropped"));
    assert_eq!(n(&once, "unique_triangles"), n(&full, "unique_triangles"));
    // Each mesh is cleaned once, in its own frame: every use keeps the same triangles.
    assert_eq!(n(&full, "degenerate_triangles_dropped"), n(&once, "degenerate_triangles_dropped"));
    assert!(n(&full, "instanced_triangles") > n(&full, "input_triangles") - n(&once, "input_triangles"));
}

/// Triangles of every mesh of a GLB, from its accessors.
fn glb_mesh_triangles(path: &Path) -> u64 {
    let mut triangles = 0;
    edit_glb(path, |doc| {
        for m in doc["meshes"].as_array().unwrap() {
            for p in m["primitives"].as_array().unwrap() {
                triangles += doc["accessors"][p["indices"].as_u64().unwrap() as usize]["count"].as_u64().unwrap() / 3;
            }
        }
    });
    triangles
}

/// The Khronos engine and its EXT_mesh_gpu_instancing variant with each mesh stored once
/// (`--instances keep`, the default) against a placed copy per use (`expand`, the blocks placed
/// at the build): the same node table, the same geometry read back, and at tau 0 the same
/// visible sets and frames in prev and the switch; at tau 1 no node culled that exact
/// visibility of the same LODs finds visible, and the same image error as the copies.
#[test]
fn the_engines_meshes_stored_once_draw_as_their_copies() {
    let d = tempfile::tempdir().unwrap();
    for model in ["2CylinderEngine.glb", "2CylinderEngine.instanced.glb"] {
        let Some(file) = real_model("the_engines_meshes_stored_once_draw_as_their_copies", model) else { continue };
        let [keep, expand] = ["keep", "expand"].map(|m| d.path().join(format!("{model}-{m}.osw")));
        for (scene, m) in [(&keep, "keep"), (&expand, "expand")] {
            osw_ok(&["build", s(&file), "--instances", m, "-o", s(scene)]);
        }
        let report = |p: &Path| -> serde_json::Value {
            serde_json::from_str(&std::fs::read_to_string(p.with_extension("build.json")).unwrap()).unwrap()
        };
        let (rk, re) = (report(&keep), report(&expand));
        let n = |r: &serde_json::Value, k: &str| r[k].as_u64().unwrap_or_else(|| panic!("no {k} in {r}"));
        // Stored once: the unique triangles are the file's meshes' less the degenerate ones.
        assert_eq!(n(&rk, "unique_triangles"), glb_mesh_triangles(&file) - n(&rk, "degenerate_triangles_dropped"), "{model}");
        assert!(n(&rk, "instances") >= 52 && n(&rk, "prototypes") >= 14, "{model}: {rk}");
        assert!(n(&rk, "stored_triangles") < n(&re, "stored_triangles"), "{model}: {rk} vs {re}");
        assert!(n(&rk, "output_bytes") + n(&rk, "bytes_saved") / 2 < n(&re, "output_bytes"), "{model}: {rk} vs {re}");
        assert!(re["left_out"].to_string().contains("(--instances expand)"), "{re}");
        let (a, b) = (SceneFile::open(&keep).unwrap(), SceneFile::open(&expand).unwrap());
        check_invariants(&a);
        assert!(a.instances().len() as u64 >= n(&rk, "instances") && b.instances().is_empty());
        let unplaced = |f: &SceneFile| f.nodes().iter().map(|n| osw_scene::NodeRecord { instance: u32::MAX, ..*n }).collect::<Vec<_>>();
        assert!(unplaced(&a) == unplaced(&b), "{model}: node tables differ beyond their instances");
        for l in a.bvh_count()..a.nodes().len() as u32 {
            let (ga, gb) = (a.geometry(l).unwrap(), b.geometry(l).unwrap());
            assert!(ga.positions == gb.positions && ga.clusters == gb.clusters, "{model}: LOD node {l} placed otherwise");
            assert!(ga.indices.iter().eq(gb.indices.iter()), "{model}: LOD node {l} indices");
        }
        let placed = a.nodes().iter().filter(|n| n.instance != u32::MAX).count();
        assert!(placed > a.nodes().len() / 2, "{model}: {placed} nodes of instances");

        let path = camera_path(&keep, "orbit", 8);
        let run = |scene: &Path, args: &[&str], out: &Path| {
            let walk = ["--scene", s(scene), "--path", s(&path), "--size", SIZE, "--out", s(out)];
            osw_ok(&[args, &walk[..]].concat());
        };
        for (name, args) in [
            ("prev", &["render", "--mode", "prev", "--tau", "0", "--always-cull"][..]),
            ("switch", &["run", "--tau", "0", "--always-cull"]),
        ] {
            let [ka, ea] = ["keep", "expand"].map(|m| d.path().join(format!("{model}-{name}-{m}")));
            run(&keep, args, &ka);
            run(&expand, args, &ea);
            let pvs = |r: &Path| std::fs::read_to_string(r.join("pvs.txt")).unwrap();
            assert_eq!(pvs(&ka), pvs(&ea), "{model} {name}: visible sets");
            // A use's normals turn on the GPU in f32, a copy's on the CPU (stored rounded): a
            // level apart where the light rounds between them.
            let (off, far_off) = (differing(&ka, &ea, 8), differing_by(&ka, &ea, 8, 1));
            assert!(off <= 1e-3 && far_off <= 1e-4, "{model} {name}: {off} of the pixels differ, {far_off} by more than a level");
        }
        let exact = d.path().join(format!("{model}-exact1"));
        osw_ok(&["exact", "--scene", s(&keep), "--path", s(&path), "--size", SIZE, "--tau", "1", "--out", s(&exact)]);
        let mut psnr = Vec::new();
        for (m, scene) in [("keep", &keep), ("expand", &expand)] {
            // Against its own full detail: a use's normals and a copy's round a level apart.
            let full = d.path().join(format!("{model}-full-{m}"));
            run(scene, &["render", "--mode", "vfc", "--tau", "0"], &full);
            let out = d.path().join(format!("{model}-prev1-{m}"));
            run(scene, &["render", "--mode", "prev", "--tau", "1", "--always-cull"], &out);
            let cmp = d.path().join(format!("{model}-cmp1-{m}"));
            let args = ["--a", s(&out), "--b", s(&out), "--exact", s(&exact), "--exact-lod", s(&exact), "--out", s(&cmp)];
            if m == "keep" {
                osw_ok(&[&["compare"], &args[..]].concat());
                let c: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(cmp.join("compare.json")).unwrap()).unwrap();
                assert_eq!(c["culling_a"]["lod_false_culled_total"], 0, "{model}: a visible node culled at tau 1: {c}");
                assert_eq!(c["culling_a"]["lod_not_drawn_total"], 0, "{model}: a visible LOD not drawn at tau 1: {c}");
            }
            psnr.push(mean_psnr(&out, &full));
        }
        assert!((psnr[0] - psnr[1]).abs() <= 0.5, "{model}: PSNR at tau 1 {psnr:?} (stored once, copies)");
    }
}

/// Mean PSNR (dB) of run `a`'s frames against run `b`'s; identical frames count as 100 dB.
fn mean_psnr(a: &Path, b: &Path) -> f64 {
    let p: Vec<f64> = (0..8u64)
        .map(|i| {
            let ((_, _, pa), (_, _, pb)) = (read_png(&frame_path(a, i)).unwrap(), read_png(&frame_path(b, i)).unwrap());
            image_error(&pa, &pb).psnr_db.unwrap_or(100.0)
        })
        .collect();
    p.iter().sum::<f64>() / p.len() as f64
}

/// A GLB's JSON chunk.
fn glb_json(path: &Path) -> serde_json::Value {
    let b = std::fs::read(path).unwrap();
    let len = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&b[20..20 + len]).unwrap()
}

/// The build stores the base colour textures its primitives sample, each image once, and names
/// in the report's `left_out` those it cannot read, counted against the file's own JSON: a
/// fixture of five quads (a textured quad with texture coordinates, a textured one without, a
/// cut-out and a specular-glossiness material whose textures are missing, a plain colour), and
/// forza where it is (129 textures, every one read). The quad without coordinates is drawn in
/// its texture's mean colour (taken here in linear light from its texels).
#[test]
fn textures_are_stored_once_and_unread_ones_are_named_in_left_out() {
    let d = tempfile::tempdir().unwrap();
    let glb = d.path().join("textured.glb");
    let (mut bin, mut views, mut accessors, mut meshes, mut nodes) = (Vec::<u8>::new(), vec![], vec![], vec![], vec![]);
    for k in 0..5 {
        let mut m = osw_scene::mesh::Mesh::default();
        let x = 2.0 * k as f32;
        m.positions = vec![[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x + 1.0, 1.0, 0.0], [x, 1.0, 0.0]];
        m.indices = vec![0, 1, 2, 0, 2, 3];
        if k == 4 {
            let uv = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
            m.texcoords = uv.iter().map(|&uv| osw_scene::texture::Texcoord { uv, texture: 0 }).collect();
        }
        let mut prim = push_mesh(&mut bin, &mut views, &mut accessors, &m);
        prim["material"] = json!(k % 4);
        meshes.push(json!({"primitives": [prim]}));
        nodes.push(json!({"mesh": k}));
    }
    let materials = json!([
        {"name": "grass", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
        {"name": "fence", "alphaMode": "MASK", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
        {"name": "paint", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.0, 0.0, 1.0]}},
        {"name": "gloss", "extensions": {"KHR_materials_pbrSpecularGlossiness": {"diffuseTexture": {"index": 2}}}},
    ]);
    let doc = json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 2, 3, 4]}], "nodes": nodes, "meshes": meshes,
        "materials": materials, "textures": [{"source": 0}, {"source": 1}, {"source": 2}],
        "images": [{"uri": "grass.png"}, {"uri": "fence.png"}, {"uri": "marble.jpg"}],
        "extensionsUsed": ["KHR_materials_pbrSpecularGlossiness"], "accessors": accessors, "bufferViews": views});
    write_glb(&glb, doc, &bin);
    let grass = [[40u8, 160, 40, 255], [90, 120, 30, 255], [40, 160, 40, 255], [10, 200, 60, 255]];
    image::RgbaImage::from_raw(2, 2, grass.concat()).unwrap().save(d.path().join("grass.png")).unwrap();
    let linear = |c: u8| ((c as f64 / 255.0 + 0.055) / 1.055).powf(2.4);
    let mean = |k: usize| grass.iter().map(|t| linear(t[k])).sum::<f64>() / 4.0;
    let want = [0, 1, 2].map(|k| ((1.055 * mean(k).powf(1.0 / 2.4) - 0.055) * 255.0).round() as u8);
    let (_, report) = build(&glb);
    let lines: Vec<String> = report["left_out"].as_array().unwrap().iter().map(|l| l.as_str().unwrap().to_owned()).collect();
    let has = |lines: &[String], needle: &str| lines.iter().any(|l| l.contains(needle));
    assert!(
        has(&lines, "2 base colour textures that cannot be read") && has(&lines, "'fence.png' (") && has(&lines, "'marble.jpg' ("),
        "{lines:?}"
    );
    assert!(!has(&lines, "'grass.png'"), "{lines:?}");
    assert!(report["notes"].to_string().contains("no TEXCOORD_0 for its base colour texture"), "{report}");
    // One image of 2x2 texels: 16 bytes, and its levels of 1x1, 4.
    assert_eq!([&report["images"], &report["textures"], &report["texel_bytes"]].map(|v| v.as_u64()), [Some(1), Some(1), Some(20)]);
    let scene = SceneFile::open(&glb.with_extension("osw")).unwrap();
    assert_eq!(scene.texels(0).unwrap()[..16], grass.concat()[..], "level 0 is the image as it is");
    let geometry: Vec<_> = (scene.bvh_count()..scene.nodes().len() as u32).map(|l| scene.geometry(l).unwrap()).collect();
    let colours: Vec<[u8; 4]> = geometry.iter().flat_map(|g| g.colors.to_vec()).collect();
    assert!(colours.iter().any(|c| c[..3] == want), "the grass quad in its texture's mean {want:?}: {colours:?}");
    let sampled: Vec<[f32; 2]> = geometry.iter().flat_map(|g| g.texcoords.iter().map(|t| t.uv)).collect();
    assert!(sampled.len() >= 4 && sampled.contains(&[1.0, 0.0]), "the tiles quad samples its texture: {sampled:?}");
    let Some(forza) = real_model("textures_are_stored_once_and_unread_ones_are_named_in_left_out", "torcs-forza.glb") else { return };
    let copy = d.path().join("forza.glb");
    std::fs::copy(&forza, &copy).unwrap();
    // The reference: the file's materials, read as plain JSON.
    let j = glb_json(&copy);
    let sources: std::collections::BTreeSet<u64> = j["materials"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|m| m["pbrMetallicRoughness"]["baseColorTexture"]["index"].as_u64())
        .map(|t| j["textures"][t as usize]["source"].as_u64().unwrap())
        .collect();
    let (_, report) = build(&copy);
    assert_eq!(report["images"].as_u64(), Some(sources.len() as u64), "{report}");
    assert!(sources.len() > 100 && !report["left_out"].to_string().contains("cannot be read"), "{report}");
}

/// An OBJ's diffuse textures are sampled at its `vt` (v flipped to glTF's, down the image),
/// its surfaces without `vt` drawn in Kd times the texture's mean; those it cannot read and its
/// alpha textures (map_d) are named in `left_out`, and a material with one makes cut-outs, with
/// a Kd or without: a hedge of two triangles before a wall of two, a grate of one, and a tile of
/// one with texture coordinates.
#[test]
fn an_objs_textures_are_sampled_or_named_and_its_alpha_textured_surfaces_are_cut_outs() {
    let d = tempfile::tempdir().unwrap();
    let obj = d.path().join("garden.obj");
    std::fs::write(
        d.path().join("garden.mtl"),
        "newmtl hedge\nKd 0.1 0.5 0.1\nmap_Kd hedge.png\nmap_d hedge_alpha.png\nnewmtl wall\nKd 0.6 0.6 0.6\nmap_Kd bricks.jpg\nnewmtl plaster\nKd 0.9 0.9 0.9\nnewmtl grate\nmap_d grate.png\nnewmtl tile\nmap_Kd hedge.png\n",
    )
    .unwrap();
    std::fs::write(
        &obj,
        "mtllib garden.mtl\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nv 0 0 -1\nv 2 0 -1\nv 2 1 -1\nv 0 1 -1\nvt 0 0\nvt 1 0\nvt 1 1\no hedge\nusemtl hedge\nf 1 2 3 4\no wall\nusemtl wall\nf 5 6 7 8\no post\nusemtl plaster\nf 1 5 8\no grate\nusemtl grate\nf 2 6 7\no tile\nusemtl tile\nf 5/1 6/2 7/3\n",
    )
    .unwrap();
    let (_, report) = build(&obj);
    assert_eq!((report["cut_out_triangles"].as_u64(), report["cut_out_objects"].as_u64()), (Some(3), Some(2)), "{report}");
    let left_out = report["left_out"].to_string();
    assert!(
        left_out.contains("2 alpha textures (map_d) apart from their diffuse texture")
            && left_out.contains("'grate.png', 'hedge_alpha.png'"),
        "{left_out}"
    );
    assert!(left_out.contains("2 diffuse textures that cannot be read (drawn in their Kd): 'bricks.jpg' ("), "{left_out}");
    // With the hedge's texture beside it (one colour): the hedge in Kd times that colour, as
    // displayed; the tile samples it.
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 255])).save(d.path().join("hedge.png")).unwrap();
    let (scene, report) = build(&obj);
    let left_out = report["left_out"].to_string();
    assert!(left_out.contains("1 diffuse textures that cannot be read") && !left_out.contains("'hedge.png' ("), "{left_out}");
    assert_eq!(report["images"].as_u64(), Some(1), "{report}");
    let geometry: Vec<_> = (scene.bvh_count()..scene.nodes().len() as u32).map(|l| scene.geometry(l).unwrap()).collect();
    let colours: Vec<[u8; 4]> = geometry.iter().flat_map(|g| g.colors.to_vec()).collect();
    assert!(colours.contains(&[20, 50, 5, osw_scene::mesh::CUT_OUT]), "the hedge in Kd times its texture: {colours:?}");
    let mut uv: Vec<[f32; 2]> = geometry.iter().flat_map(|g| g.texcoords.iter().map(|t| t.uv)).collect();
    uv.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(uv, [[0.0, 1.0], [1.0, 0.0], [1.0, 1.0]], "the tile's vt 0 0, 1 0 and 1 1, v flipped");
}
