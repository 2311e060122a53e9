//! `osw path`: the CSV format, determinism, and walks that stay out of walls, checked against
//! the full-detail triangles of the scene (closest distance and segment crossings).

mod common;
use common::*;
use glam::{DVec3, Vec3};
use osw_scene::SceneFile;
use osw_scene::format::NodeKind;
use osw_scene::mesh::closest_on_triangle;

/// Does segment pq cross triangle abc (Möller-Trumbore on the segment)?
fn segment_hits(p: Vec3, q: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    let d = q - p;
    let (e1, e2) = (b - a, c - a);
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-12 {
        return false;
    }
    let s = p - a;
    let u = s.dot(h) / det;
    let qv = s.cross(e1);
    let v = d.dot(qv) / det;
    let t = e2.dot(qv) / det;
    (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && (0.0..=1.0).contains(&t)
}

/// The scene's full-detail opaque triangles, scene-local.
fn opaque_triangles(scene: &SceneFile) -> Vec<[Vec3; 3]> {
    let mut tris = Vec::new();
    for id in 0..scene.bvh_count() {
        let n = scene.node(id);
        if n.kind() == NodeKind::Leaf {
            let g = scene.geometry(n.first_lod).unwrap();
            for t in 0..g.opaque_indices() / 3 {
                tris.push([0, 1, 2].map(|k| Vec3::from_array(g.positions[g.indices.get(t * 3 + k) as usize])));
            }
        }
    }
    tris
}

/// Smallest distance from any camera to any full-detail opaque triangle, and how many steps of
/// the path cross one (a walk goes through translucent room volumes).
fn clearance(scene: &SceneFile, cams: &[osw_scene::Camera]) -> (f32, usize) {
    let local: Vec<Vec3> = cams.iter().map(|c| (c.position - scene.origin()).as_vec3()).collect();
    let tris = opaque_triangles(scene);
    let near = |p: Vec3, r: f32| {
        let (lo, hi) = (p - Vec3::splat(r), p + Vec3::splat(r));
        tris.iter().filter(move |t| {
            let (tl, th) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            tl.cmple(hi).all() && lo.cmple(th).all()
        })
    };
    let mut min_d = f32::INFINITY;
    let mut crossings = 0;
    for (i, &p) in local.iter().enumerate() {
        for t in near(p, 2.0) {
            min_d = min_d.min(closest_on_triangle(p, t[0], t[1], t[2]).distance(p));
        }
        if let Some(&q) = local.get(i + 1) {
            crossings += near(p, p.distance(q) + 0.1).filter(|t| segment_hits(p, q, t[0], t[1], t[2])).count();
        }
    }
    (min_d, crossings)
}

#[test]
fn walks_stay_out_of_walls_and_paths_are_deterministic() {
    let d = tempfile::tempdir().unwrap();
    for kind in ["plant", "city", "teapots"] {
        let scene_path = build_gen(d.path(), kind, 300_000, 2);
        let scene = SceneFile::open(&scene_path).unwrap();
        let csv = d.path().join(format!("{kind}.csv"));
        let args = |seed: &str, out: &std::path::Path| {
            vec![
                "path".to_string(),
                "--scene".into(),
                scene_path.display().to_string(),
                "--kind".into(),
                "walk".into(),
                "--frames".into(),
                "300".into(),
                "--seed".into(),
                seed.into(),
                "-o".into(),
                out.display().to_string(),
            ]
        };
        let run = |a: Vec<String>| osw_ok(&a.iter().map(String::as_str).collect::<Vec<_>>());
        run(args("5", &csv));
        let cams = osw_scene::path::read(&csv).unwrap();
        assert_eq!(cams.len(), 300);
        let (min_d, crossings) = clearance(&scene, &cams);
        eprintln!("{kind}: min distance {min_d}, crossings {crossings}");
        assert_eq!(crossings, 0, "{kind}: the walk passes through geometry");
        assert!(min_d >= 0.2, "{kind}: the walk comes within {min_d} m of a surface");
        // The walk moves.
        let travelled: f64 = cams.windows(2).map(|w| w[0].position.distance(w[1].position)).sum();
        assert!(travelled > 30.0, "{kind}: walked only {travelled} m");
        let again = d.path().join("again.csv");
        run(args("5", &again));
        assert_eq!(std::fs::read(&csv).unwrap(), std::fs::read(&again).unwrap(), "{kind}: same seed, different path");
        run(args("6", &again));
        assert_ne!(std::fs::read(&csv).unwrap(), std::fs::read(&again).unwrap(), "{kind}: seed ignored");
    }
}

/// A two-storey building as an IFC export makes one: slabs, outer walls, a partition with a
/// doorway 1 m wide, a straight stair of 16 steps up through a hole in the upper slab, a roof,
/// and each storey filled by a translucent room volume (IfcSpace, alpha 0.2). With `yard`, a
/// door in the wall at x = 10 leads out onto a paved yard 4 m deep.
fn write_building(path: &std::path::Path, yard: bool) {
    let mut parts: Vec<([f32; 6], f64)> = vec![
        ([0.0, -0.3, 0.0, 10.0, 0.0, 8.0], 1.0), // ground slab
        ([0.0, 2.8, 0.0, 10.0, 3.0, 5.0], 1.0),  // upper slab, less the stairwell
        ([0.0, 2.8, 5.0, 4.0, 3.0, 8.0], 1.0),
        ([0.0, 5.8, 0.0, 10.0, 6.0, 8.0], 1.0),   // roof
        ([-0.2, -0.3, -0.2, 0.0, 6.0, 8.2], 1.0), // outer walls
        ([0.0, -0.3, -0.2, 10.0, 6.0, 0.0], 1.0),
        ([0.0, -0.3, 8.0, 10.0, 6.0, 8.2], 1.0),
        ([2.0, 0.0, 0.0, 2.15, 2.8, 1.0], 1.0), // a partition with a doorway at z 1..2
        ([2.0, 0.0, 2.0, 2.15, 2.8, 8.0], 1.0),
        ([2.0, 2.1, 1.0, 2.15, 2.8, 2.0], 1.0), // its lintel
        ([0.0, 0.0, 0.0, 10.0, 2.8, 8.0], 0.2), // room volumes
        ([0.0, 3.0, 0.0, 10.0, 5.8, 8.0], 0.2),
    ];
    for k in 1..=16 {
        let x = 4.0 + (16 - k) as f32 * 0.3;
        parts.push(([x, 0.0, 5.2, x + 0.3, k as f32 * 0.1875, 7.8], 1.0));
    }
    parts.extend(match yard {
        false => vec![([10.0, -0.3, -0.2, 10.2, 6.0, 8.2], 1.0)],
        // The wall at x = 10 with a door at z 3..4.5, and the yard's paving.
        true => vec![
            ([10.0, -0.3, -0.2, 10.2, 6.0, 3.0], 1.0),
            ([10.0, -0.3, 4.5, 10.2, 6.0, 8.2], 1.0),
            ([10.0, 2.1, 3.0, 10.2, 6.0, 4.5], 1.0),
            ([10.0, -0.3, 0.0, 14.0, 0.0, 8.0], 1.0),
        ],
    });
    write_boxes(path, &parts);
}

/// A glTF of boxes (min x, y, z, max x, y, z), each with its alpha (below 1: blended).
fn write_boxes(path: &std::path::Path, parts: &[([f32; 6], f64)]) {
    let (mut bin, mut views, mut accessors, mut meshes, mut nodes) = (vec![], vec![], vec![], vec![], vec![]);
    for (k, (b, alpha)) in parts.iter().enumerate() {
        let mut m = osw_scene::mesh::Mesh::default();
        osw_scene::generators::shapes::add_box(&mut m, Vec3::new(b[0], b[1], b[2]), Vec3::new(b[3], b[4], b[5]));
        let mut prim = push_mesh(&mut bin, &mut views, &mut accessors, &m);
        prim["material"] = serde_json::json!(usize::from(*alpha < 1.0));
        meshes.push(serde_json::json!({"primitives": [prim]}));
        nodes.push(serde_json::json!({"mesh": k}));
    }
    let materials = serde_json::json!([
        {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0]}},
        {"alphaMode": "BLEND", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.7, 0.8, 0.2]}},
    ]);
    let doc = serde_json::json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes, "meshes": meshes, "materials": materials, "accessors": accessors, "bufferViews": views});
    write_glb(path, doc, &bin);
}

#[test]
fn a_walk_goes_through_doorways_room_volumes_and_up_the_stairs_of_a_building() {
    let d = tempfile::tempdir().unwrap();
    let (glb, scene_path, csv) = (d.path().join("house.glb"), d.path().join("house.osw"), d.path().join("walk.csv"));
    write_building(&glb, false);
    osw_ok(&["build", s(&glb), "-o", s(&scene_path)]);
    osw_ok(&["path", "--scene", s(&scene_path), "--kind", "walk", "--frames", "600", "--seed", "3", "-o", s(&csv)]);
    let scene = SceneFile::open(&scene_path).unwrap();
    let cams = osw_scene::path::read(&csv).unwrap();
    let (min_d, crossings) = clearance(&scene, &cams);
    assert_eq!(crossings, 0, "the walk passes through walls, slabs or steps");
    assert!(min_d >= 0.2, "the walk comes within {min_d} m of a surface");
    // Inside, on both storeys (eyes 1.7 above each floor), and on both sides of the partition.
    let eye = |c: &osw_scene::Camera| c.position.y as f32;
    for c in &cams {
        let p = c.position;
        assert!(p.x > 0.0 && p.x < 10.0 && p.z > 0.0 && p.z < 8.0, "outside the building at {p}");
    }
    let ground = cams.iter().filter(|c| (eye(c) - 1.7).abs() < 0.05).collect::<Vec<_>>();
    let upper = cams.iter().filter(|c| (eye(c) - 4.7).abs() < 0.05).count();
    let climbing = cams.len() - ground.len() - upper;
    eprintln!("{} frames on the ground floor, {upper} upstairs, {climbing} on the stairs", ground.len());
    assert!(!ground.is_empty() && upper > 0 && climbing > 0, "{} on the ground floor, {upper} upstairs, {climbing} between", ground.len());
    assert!(ground.iter().any(|c| c.position.x < 2.0) && ground.iter().any(|c| c.position.x > 2.15), "never through the doorway");
}

/// A walk starts under the roof of the region it walks in, though that region reaches out of
/// a door onto open ground (a site's roads are its buildings' ground floors' region).
#[test]
fn a_walk_starts_inside_though_its_region_reaches_outside() {
    let d = tempfile::tempdir().unwrap();
    let (glb, scene_path) = (d.path().join("yard.glb"), d.path().join("yard.osw"));
    write_building(&glb, true);
    osw_ok(&["build", s(&glb), "-o", s(&scene_path)]);
    let walk = |seed: u64, frames: &str, speed: &str| {
        let csv = d.path().join(format!("walk-{seed}-{frames}.csv"));
        let seed = seed.to_string();
        osw_ok(&[
            "path",
            "--scene",
            s(&scene_path),
            "--kind",
            "walk",
            "--frames",
            frames,
            "--speed",
            speed,
            "--seed",
            &seed,
            "-o",
            s(&csv),
        ]);
        osw_scene::path::read(&csv).unwrap()
    };
    // The yard is walked: long walks go out of the door.
    let out = (1..=8).filter(|&seed| walk(seed, "600", "0.25").iter().any(|c| c.position.x > 10.4)).count();
    assert!(out > 0, "no walk of 600 frames goes out into the yard");
    // Every walk starts inside (slowly: the smoothing averages the first 0.6 m).
    for seed in 1..=24 {
        let p = walk(seed, "2", "0.05")[0].position;
        assert!(p.x < 10.0, "seed {seed}: the walk starts in the yard at {p}");
    }
}

#[test]
fn orbit_and_flyover_look_at_the_scene_from_outside() {
    let d = tempfile::tempdir().unwrap();
    let scene_path = build_gen(d.path(), "plant", 100_000, 1);
    let scene = SceneFile::open(&scene_path).unwrap();
    let root = scene.node(0).aabb();
    let centre = scene.origin() + root.center().as_dvec3();
    for kind in ["orbit", "flyover"] {
        let csv = d.path().join(format!("{kind}.csv"));
        osw_ok(&["path", "--scene", scene_path.to_str().unwrap(), "--kind", kind, "--frames", "120", "-o", csv.to_str().unwrap()]);
        let cams = osw_scene::path::read(&csv).unwrap();
        assert_eq!(cams.len(), 120);
        for c in &cams {
            let local = (c.position - scene.origin()).as_vec3();
            assert!(!root.contains_point(local), "{kind}: camera inside the scene box");
            if kind == "orbit" {
                // Looking at the centre.
                assert!(c.forward().dot((centre - c.position).normalize()) > 0.999, "orbit: not looking at the centre");
            } else {
                assert!(local.y > root.max.y && c.forward().y < -0.1, "flyover: not above the scene looking down");
            }
        }
    }
}

#[test]
fn a_walk_through_an_offset_scene_is_the_same_walk_moved() {
    let d = tempfile::tempdir().unwrap();
    let (near, far) = (d.path().join("near.osw"), d.path().join("far.osw"));
    osw_ok(&["build", "--gen", "city", "--triangles", "100000", "-o", near.to_str().unwrap()]);
    osw_ok(&["build", "--gen", "city", "--triangles", "100000", "--offset", "1e7,0,1e7", "-o", far.to_str().unwrap()]);
    let walk = |s: &std::path::Path, name: &str| {
        let csv = d.path().join(name);
        osw_ok(&["path", "--scene", s.to_str().unwrap(), "--kind", "walk", "--frames", "50", "-o", csv.to_str().unwrap()]);
        osw_scene::path::read(&csv).unwrap()
    };
    let (a, b) = (walk(&near, "a.csv"), walk(&far, "b.csv"));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(y.position - DVec3::new(1e7, 0.0, 1e7), x.position);
        assert_eq!(x.orientation, y.orientation);
    }
}

/// How far below each camera the first opaque full-detail triangle lies, straight down
/// (infinite where none does): each triangle's height at the camera's x and z, from its
/// barycentric coordinates there.
fn ground_below(scene: &SceneFile, cams: &[osw_scene::Camera]) -> Vec<f32> {
    let tris = opaque_triangles(scene);
    let below = |p: Vec3| {
        let height = |t: &[Vec3; 3]| {
            let [a, b, c] = t.map(|v| glam::Vec2::new(v.x, v.z));
            let q = glam::Vec2::new(p.x, p.z);
            let area = (b - a).perp_dot(c - a);
            if area.abs() < 1e-9 {
                return None;
            }
            let (u, v) = ((q - a).perp_dot(c - a) / area, (b - a).perp_dot(q - a) / area);
            let y = t[0].y + u * (t[1].y - t[0].y) + v * (t[2].y - t[0].y);
            (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && y <= p.y).then_some(p.y - y)
        };
        tris.iter().filter_map(height).fold(f32::INFINITY, f32::min)
    };
    cams.iter().map(|c| below((c.position - scene.origin()).as_vec3())).collect()
}

/// A model with ground of its own is walked on it: a terrain 40 m square raised 3 m on a
/// post, beside a mast 20 m off whose foot is the model's lowest point. Under the terrain,
/// every cell's floor at the lowest point is free, larger than the terrain and mostly roofed
/// (the walk of an inside): a walk there sees the terrain from below. On forza (a race
/// circuit whose lowest point lies under its terrain), the walk keeps eye height over the
/// circuit's surfaces.
#[test]
fn a_walk_goes_on_a_models_own_ground_not_under_it() {
    let d = tempfile::tempdir().unwrap();
    let (glb, scene_path) = (d.path().join("terrain.glb"), d.path().join("terrain.osw"));
    write_boxes(
        &glb,
        &[([0.0, 3.0, 0.0, 40.0, 3.2, 40.0], 1.0), ([19.5, 0.0, 19.5, 20.5, 3.0, 20.5], 1.0), ([60.0, 0.0, 0.0, 61.0, 8.0, 1.0], 1.0)],
    );
    osw_ok(&["build", s(&glb), "-o", s(&scene_path)]);
    let walk = |scene: &std::path::Path, frames: &str| {
        let csv = d.path().join(format!("{}.csv", scene.file_stem().unwrap().to_str().unwrap()));
        osw_ok(&["path", "--scene", s(scene), "--kind", "walk", "--frames", frames, "-o", s(&csv)]);
        osw_scene::path::read(&csv).unwrap()
    };
    let cams = walk(&scene_path, "200");
    let below = ground_below(&SceneFile::open(&scene_path).unwrap(), &cams);
    for (k, (c, h)) in cams.iter().zip(&below).enumerate() {
        assert!((h - osw_scene::nav::EYE).abs() < 0.01, "frame {k} at {}: the terrain {h} m below", c.position);
    }
    let Some(forza) = real_model("a_walk_goes_on_a_models_own_ground_not_under_it", "torcs-forza.glb") else { return };
    let scene_path = d.path().join("forza.osw");
    osw_ok(&["build", s(&forza), "-o", s(&scene_path)]);
    let cams = walk(&scene_path, "300");
    let below = ground_below(&SceneFile::open(&scene_path).unwrap(), &cams);
    for (k, (c, h)) in cams.iter().zip(&below).enumerate() {
        assert!((h - osw_scene::nav::EYE).abs() < 0.05, "forza frame {k} at {}: the first surface {h} m below", c.position);
    }
}

#[test]
fn a_model_with_nowhere_to_stand_is_refused_by_name() {
    // One wall, 10 m square: every floor of the grid (the wall's foot) is blocked by it.
    let d = tempfile::tempdir().unwrap();
    let (ply, scene) = (d.path().join("wall.ply"), d.path().join("wall.osw"));
    let header = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    std::fs::write(&ply, format!("{header}0 0 0\n10 0 0\n10 10 0\n0 10 0\n4 0 1 2 3\n")).unwrap();
    osw_ok(&["build", s(&ply), "-o", s(&scene)]);
    let csv = d.path().join("walk.csv");
    osw_err(&["path", "--scene", s(&scene), "--kind", "walk", "-o", s(&csv)], "no free space to walk in at eye height");
    assert!(!csv.exists(), "no path written");
    // Orbits and flyovers need no floor.
    osw_ok(&["path", "--scene", s(&scene), "--kind", "orbit", "--frames", "4", "-o", s(&csv)]);
}
