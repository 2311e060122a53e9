//! Shading with normals (osw_scene::normal): a pipe of 32 facets with computed normals shades
//! round, measured where its facets meet (their edges projected on the CPU) against the steps
//! inside each facet; a box stays flat, pixel for pixel as a build without normals draws it;
//! normals a model gives (glTF NORMAL, OBJ vn, PLY nx ny nz) are used as given, bent away from
//! their faces on purpose; an instanced pipe's normals turn with its placement on the GPU as
//! its placed copy's do on the CPU.

use glam::{DAffine3, DVec3, Vec3};
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{RenderOptions, Renderer};
use osw_scene::build::Instances;
use osw_scene::generators::shapes;
use osw_scene::mesh::{Mesh, Object};
use osw_scene::smooth::Normals;
use osw_scene::{BuildOptions, Camera, SceneFile};
use std::path::Path;

const W: u32 = 320;
const H: u32 = 240;
const FOVY: f64 = 50.0;
/// The camera stands on +Z, looking at the origin.
const EYE: f64 = 4.0;
/// The light of shaders/draw.wgsl.
const LIGHT: Vec3 = Vec3::new(0.4, 0.8, 0.3);

fn build(dir: &Path, name: &str, objects: Vec<Object>, normals: Normals, instances: Instances) -> SceneFile {
    let path = dir.join(format!("{name}.osw"));
    let opts = BuildOptions { normals, instances, ..Default::default() };
    osw_scene::build_scene(objects, name, Vec::new(), &opts, &path, std::time::Instant::now(), &()).unwrap();
    SceneFile::open(&path).unwrap()
}

/// Every leaf at full detail, RGBA8 rows.
fn frame(scene: &SceneFile) -> Vec<u8> {
    let gpu = osw_gpu::Gpu::new(None).expect("a Vulkan adapter (lavapipe: mesa-vulkan-drivers)");
    let mut r = Renderer::new(gpu, scene, W, H, RenderOptions::default()).unwrap();
    let view = r.view(&Camera::look_at(DVec3::new(0.0, 0.0, EYE), DVec3::ZERO, FOVY), 0.0);
    let lods: Vec<u32> = (0..scene.bvh_count()).map(|i| scene.node(i)).filter(|n| n.child_count == 0).map(|n| n.first_lod).collect();
    r.begin_frame();
    r.draw(scene, &view, &lods, Pass::Color, Load::Clear).unwrap();
    r.read_color().unwrap()
}

/// Pixel column of a point on the camera's side, at the image's middle row.
fn column(p: Vec3) -> f64 {
    let x_ndc = p.x as f64 / (EYE - p.z as f64) / ((FOVY.to_radians() / 2.0).tan() * W as f64 / H as f64);
    (x_ndc + 1.0) / 2.0 * W as f64
}

/// The largest difference of a channel between two pixels.
fn step(a: &[u8], b: &[u8]) -> u8 {
    (0..3).map(|k| a[k].abs_diff(b[k])).max().unwrap()
}

/// A vertical pipe of radius 1.4 and 32 facets, grey, with its rim's corners.
fn pipe() -> (Mesh, Vec<Vec3>) {
    let mut m = Mesh::default();
    shapes::tube(&mut m, &[Vec3::new(0.0, -3.0, 0.0), Vec3::new(0.0, 3.0, 0.0)], 1.4, 32, false);
    m.paint([200, 200, 200, 255]);
    let rim = m.positions.iter().map(|&p| Vec3::from_array(p)).filter(|p| p.y < -2.9).collect();
    (m, rim)
}

/// For each facet edge facing the camera well inside the silhouette: the step across it and the
/// largest step inside either facet beside it, along the middle row.
fn edges(rgba: &[u8], rim: &[Vec3]) -> Vec<(u8, u8)> {
    let row = &rgba[(H / 2 * W * 4) as usize..((H / 2 + 1) * W * 4) as usize];
    let px = |x: usize| &row[x * 4..x * 4 + 4];
    // Edges facing the camera within 60° of it: facets there are 15 px or more wide.
    let mut at: Vec<f64> = rim.iter().filter(|p| p.z > 0.0 && p.x.abs() < 1.4 * 0.87).map(|&p| column(p)).collect();
    at.sort_by(f64::total_cmp);
    // Pixel centres lie at i + 0.5: an edge at x lies between columns floor(x - 0.5) and the next.
    let inside = |from: f64, to: f64| {
        let (a, b) = ((from + 0.5).ceil() as usize, (to - 0.5).floor() as usize);
        (a..b).map(|x| step(px(x), px(x + 1))).max().unwrap_or(0)
    };
    at.windows(3)
        .map(|w| {
            let x = (w[1] - 0.5).floor() as usize;
            (step(px(x), px(x + 1)), inside(w[0] + 1.0, w[1] - 1.0).max(inside(w[1] + 1.0, w[2] - 1.0)))
        })
        .collect()
}

#[test]
fn a_pipe_of_32_facets_shades_round_and_a_box_stays_flat() {
    let dir = tempfile::tempdir().unwrap();
    let (m, rim) = pipe();
    let smooth = frame(&build(dir.path(), "pipe", vec![Object::new("pipe", m.clone())], Normals::default(), Instances::Keep));
    let flat = frame(&build(dir.path(), "pipe-flat", vec![Object::new("pipe", m)], Normals::Flat, Instances::Keep));
    let across = edges(&smooth, &rim);
    assert!(across.len() >= 8, "{} edges measured", across.len());
    for (k, &(edge, inside)) in across.iter().enumerate() {
        assert!(edge <= inside + 1, "edge {k}: a step of {edge} across it, at most {inside} inside its facets; {across:?}");
    }
    // Drawn flat, the same edges show.
    let faceted = edges(&flat, &rim);
    assert!(faceted.iter().filter(|&&(edge, inside)| edge > inside + 1).count() * 2 > faceted.len(), "{faceted:?}");

    // A box turned to show three faces: no normals stored, drawn as flat as without any.
    let mut cube = Mesh::default();
    shapes::add_box(&mut cube, Vec3::splat(-1.0), Vec3::splat(1.0));
    cube.transform(&(glam::Affine3A::from_rotation_y(0.6) * glam::Affine3A::from_rotation_x(0.5)));
    let boxed = build(dir.path(), "box", vec![Object::new("box", cube.clone())], Normals::default(), Instances::Keep);
    assert!(boxed.blocks().iter().all(|b| b.normal_bytes == 0), "a box stores no normals");
    let (a, b) = (frame(&boxed), frame(&build(dir.path(), "box-flat", vec![Object::new("box", cube)], Normals::Flat, Instances::Keep)));
    assert!(a.chunks(4).any(|p| p != &a[..4]), "a blank frame tells nothing");
    let worst = a.chunks_exact(4).zip(b.chunks_exact(4)).map(|(p, q)| step(p, q)).max().unwrap();
    assert!(worst <= 1, "the box's pixels differ by {worst} levels from its flat build's");
}

/// A square of side 2 facing the camera, its normals all `n` as each format writes them, grey.
fn square_files(dir: &Path, n: Vec3) -> Vec<std::path::PathBuf> {
    let corners = [[-1.0f32, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]];
    let mut bytes: Vec<u8> = corners.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    bytes.extend((0..4).flat_map(|_| n.to_array()).flat_map(|c| c.to_le_bytes()));
    bytes.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    let uri = format!("data:application/octet-stream;base64,{}", base64::encode(&bytes));
    // Linear 0.578 is sRGB 200 (the others' colour).
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.5776,0.5776,0.5776,1]}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},"indices":2,"material":0}}]}}],
        "buffers":[{{"byteLength":{},"uri":"{uri}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":48}},{{"buffer":0,"byteOffset":96,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,-1,0],"max":[1,1,0]}},
        {{"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"}},{{"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#,
        bytes.len()
    );
    let v = |p: &[f32; 3]| format!("{} {} {}", p[0], p[1], p[2]);
    let obj = format!(
        "mtllib grey.mtl\nusemtl grey\n{}\nvn {} {} {}\nf 1//1 2//1 3//1 4//1\n",
        corners.iter().map(|p| format!("v {}", v(p))).collect::<Vec<_>>().join("\n"),
        n.x,
        n.y,
        n.z
    );
    let ply = format!(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n{}\n4 0 1 2 3\n",
        corners.iter().map(|p| format!("{} {} {} {} 200 200 200", v(p), n.x, n.y, n.z)).collect::<Vec<_>>().join("\n")
    );
    std::fs::write(dir.join("grey.mtl"), "newmtl grey\nKd 0.784 0.784 0.784\n").unwrap();
    let files = [("square.gltf", gltf), ("square.obj", obj), ("square.ply", ply)];
    files.iter().map(|(name, text)| std::fs::write(dir.join(name), text).map(|_| dir.join(name)).unwrap()).collect()
}

#[test]
fn normals_a_model_gives_are_used_as_given() {
    let dir = tempfile::tempdir().unwrap();
    let bent = Vec3::new(1.0, 0.0, 1.0).normalize();
    let light = |n: Vec3| 200.0 * (0.35 + 0.65 * n.dot(LIGHT.normalize()).abs());
    let (given, face) = (light(bent), light(Vec3::Z));
    assert!((given - face).abs() > 10.0, "the test tells the bent normal from the face's");
    for path in square_files(dir.path(), bent) {
        let imported = osw_scene::import::read(&path).unwrap();
        let normals = &imported.objects[0].mesh.normals;
        assert_eq!(normals.len(), imported.objects[0].mesh.positions.len(), "{}", path.display());
        let scene = build(dir.path(), "square", imported.objects, Normals::default(), Instances::Keep);
        let rgba = frame(&scene);
        let centre = &rgba[((H / 2 * W + W / 2) * 4) as usize..][..3];
        for &c in centre {
            assert!(
                (c as f32 - given).abs() <= 1.5,
                "{}: {centre:?}, given normals shade {given:.1}, the face's {face:.1}",
                path.display()
            );
        }
    }
}

#[test]
fn an_instanced_pipes_normals_turn_with_it_on_the_gpu() {
    let dir = tempfile::tempdir().unwrap();
    let (m, _) = pipe();
    // Three uses of one mesh, turned, scaled unevenly and mirrored: normals follow the
    // inverse transpose of each placement.
    let places = [
        DAffine3::from_translation(DVec3::new(-1.8, 0.0, -1.0))
            * DAffine3::from_rotation_z(0.9)
            * DAffine3::from_scale(DVec3::new(0.4, 1.0, 0.6)),
        DAffine3::from_translation(DVec3::new(0.0, 0.0, -2.0))
            * DAffine3::from_rotation_x(1.2)
            * DAffine3::from_scale(DVec3::new(0.7, 0.5, 0.3)),
        DAffine3::from_translation(DVec3::new(1.8, 0.0, -1.0)) * DAffine3::from_scale(DVec3::new(-0.5, 0.8, 0.5)),
    ];
    let objects = || -> Vec<Object> {
        let uses = places.iter().enumerate();
        uses.map(|(k, &p)| Object { prototype: Some(0), ..Object::placed(format!("use {k}"), m.clone(), DVec3::ZERO, p) }).collect()
    };
    let keep = build(dir.path(), "keep", objects(), Normals::default(), Instances::Keep);
    let expand = build(dir.path(), "expand", objects(), Normals::default(), Instances::Expand);
    assert_eq!(keep.instances().len(), 3);
    let (on_gpu, on_cpu) = (frame(&keep), frame(&expand));
    assert!(on_gpu.chunks(4).filter(|p| p != &&on_gpu[..4]).count() > 5000, "the pipes cover the frame");
    let worst = on_gpu.chunks_exact(4).zip(on_cpu.chunks_exact(4)).map(|(p, q)| step(p, q)).max().unwrap();
    assert!(worst <= 1, "normals turned on the GPU shade {worst} levels from the copies' turned on the CPU");
}
