//! Numerical stability on stiff and extreme scenes (the cameras' extremes are in render.rs):
//! every mode stays conservative against exact visibility and pixel-identical to vfc at tau 0,
//! and no statistic is NaN, on
//! - a one-node scene whose only box has zero thickness, seen face on, edge on from inside its
//!   plane, and from a camera inside the box;
//! - a hierarchy of depth ≥ 64 whose objects reach 1e11 units away (far beyond any finite far
//!   plane), partly hiding each other;
//! - a scene of over a million nodes.

mod common;
use common::*;
use glam::DVec3;
use osw_scene::{Camera, SceneFile};
use std::fmt::Write as _;
use std::path::Path;

/// An ASCII PLY of triangles.
fn write_ply(p: &Path, tris: &[[DVec3; 3]]) {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        tris.len() * 3,
        tris.len()
    );
    for v in tris.iter().flatten() {
        let _ = writeln!(s, "{} {} {}", v.x, v.y, v.z);
    }
    for k in 0..tris.len() {
        let _ = writeln!(s, "3 {} {} {}", 3 * k, 3 * k + 1, 3 * k + 2);
    }
    std::fs::write(p, s).unwrap();
}

/// Depth of the BVH: the longest parent chain from a BVH node to the root.
fn depth(scene: &SceneFile) -> u32 {
    (0..scene.bvh_count())
        .map(|mut id| {
            let mut d = 0;
            while id != 0 {
                id = scene.node(id).parent;
                d += 1;
            }
            d
        })
        .max()
        .unwrap()
}

#[test]
fn a_single_zero_thickness_node_from_inside_its_plane() {
    let d = tempfile::tempdir().unwrap();
    let (ply, scene) = (d.path().join("quad.ply"), d.path().join("quad.osw"));
    let [a, b, c, e] = [DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, -1.0, 0.0), DVec3::new(1.0, 1.0, 0.0), DVec3::new(-1.0, 1.0, 0.0)];
    // Both windings: the quad is seen from either side.
    write_ply(&ply, &[[a, b, c], [a, c, e], [a, c, b], [a, e, c]]);
    osw_ok(&["build", s(&ply), "-o", s(&scene)]);
    let sf = SceneFile::open(&scene).unwrap();
    assert_eq!(sf.bvh_count(), 1, "one node");
    let bx = sf.node(0).aabb();
    assert_eq!(bx.min.z, bx.max.z, "zero thickness");
    let o = sf.origin();
    let cams = [
        Camera::look_along(o + DVec3::new(0.0, 0.0, 3.0), DVec3::NEG_Z, 60.0),
        Camera::look_along(o + DVec3::new(0.2, 0.1, -3.0), DVec3::Z, 60.0),
        // In the quad's plane, outside it, looking along the plane: edge on.
        Camera::look_along(o + DVec3::new(-4.0, 0.0, 0.0), DVec3::X, 60.0),
        // Inside the (flat) box, looking along the plane.
        Camera::look_along(o + DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.3, 0.0), 90.0),
        // Inside the box, looking through the quad.
        Camera::look_along(o + DVec3::new(0.5, 0.5, 0.0), DVec3::new(0.0, 0.1, 1.0), 60.0),
    ];
    let path = d.path().join("p.csv");
    osw_scene::path::write(&path, &cams).unwrap();
    let run = check_conservative(d.path(), &scene, &path, "quad");
    // The check can see the quad: face on, it is exactly visible.
    let exact = std::fs::read_to_string(run.join("exact/exact.csv")).unwrap();
    assert!(exact.lines().nth(1).unwrap().split(',').nth(1) == Some("1"), "{exact}");
}

/// Writes a scene whose BVH is a chain: group k holds leaf k and group k+1, so the depth is
/// one less than the number of triangles; leaf k draws triangle k at full detail. (The SAH
/// build never makes such a tree: the file is written directly, as a foreign tool might.)
fn write_chain_scene(path: &Path, tris: &[[DVec3; 3]]) {
    use osw_scene::format::{NONE, NodeKind, NodeRecord};
    let n = tris.len() as u32;
    let bvh_count = 2 * n - 1;
    let leaf_id = |k: u32| if k + 1 == n { 2 * n - 2 } else { 2 * k + 1 };
    let bounds = |r: std::ops::Range<usize>| {
        let pts = tris[r].iter().flatten().map(|p| p.as_vec3());
        pts.fold((glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)))
    };
    let record = |kind: NodeKind, (lo, hi): (glam::Vec3, glam::Vec3), parent: u32| NodeRecord {
        bbox_min: lo.into(),
        kind: kind as u32,
        bbox_max: hi.into(),
        error: 0.0,
        parent,
        first_child: 0,
        child_count: 0,
        first_lod: 0,
        lod_count: 0,
        block: NONE,
        object: NONE,
        triangles: 0,
        flags: 0,
        cut_hi: osw_scene::format::ErrorBound { center: [0.0; 3], radius: 0.0, error: 0.0 },
        cut_lo_error: 0.0,
        instance: NONE,
        _pad: 0,
    };
    let mut nodes = vec![record(NodeKind::Group, bounds(0..1), NONE); (bvh_count + n) as usize];
    for k in 0..n - 1 {
        let g = &mut nodes[2 * k as usize];
        *g = record(NodeKind::Group, bounds(k as usize..n as usize), if k == 0 { NONE } else { 2 * (k - 1) });
        (g.first_child, g.child_count, g.triangles) = (2 * k + 1, 2, (n - k) as u64);
    }
    for k in 0..n {
        let (id, parent) = (leaf_id(k), if k + 1 == n { 2 * (n - 2) } else { 2 * k });
        let b = bounds(k as usize..k as usize + 1);
        nodes[id as usize] =
            NodeRecord { first_lod: bvh_count + k, lod_count: 1, object: k, triangles: 1, ..record(NodeKind::Leaf, b, parent) };
        nodes[(bvh_count + k) as usize] = NodeRecord { block: k, object: k, triangles: 1, ..record(NodeKind::Lod, b, id) };
    }
    let blocks = tris
        .iter()
        .map(|t| osw_scene::Mesh {
            positions: t.iter().map(|p| p.as_vec3().into()).collect(),
            indices: vec![0, 1, 2],
            ..Default::default()
        })
        .collect();
    let data = osw_scene::writer::SceneData {
        origin: [0.0; 3],
        nodes,
        bvh_count,
        blocks,
        object_count: n,
        leaf_count: n,
        leaf_triangles: n as u64,
        closed_objects: Vec::new(),
        textures: Default::default(),
    };
    osw_scene::writer::write_scene(path, &data).unwrap();
}

#[test]
fn a_deep_hierarchy_reaching_far_beyond_any_far_plane() {
    let d = tempfile::tempdir().unwrap();
    let scene = d.path().join("deep.osw");
    // Triangle k at distance 1.4^k along +x (up to ~1e11), sized with its distance so each
    // covers about the same angle, shifted sideways so that nearer ones partly hide farther
    // ones: a stiff depth range in a hierarchy of depth 75.
    let tris: Vec<[DVec3; 3]> = (0..76)
        .map(|k| {
            let x = 1.4f64.powi(k);
            let (w, y) = (0.2 * x, 0.12 * x * ((k % 5) as f64 - 2.0));
            [DVec3::new(x, y - w, -w), DVec3::new(x, y + w, -w), DVec3::new(x, y, w)]
        })
        .collect();
    write_chain_scene(&scene, &tris);
    let sf = SceneFile::open(&scene).unwrap();
    assert!(depth(&sf) >= 64, "BVH depth {} < 64", depth(&sf));
    check_invariants(&sf);
    let cams = [
        Camera::look_along(DVec3::new(0.1, 0.0, 0.0), DVec3::X, 60.0),
        Camera::look_along(DVec3::new(0.1, 0.05, 0.02), DVec3::new(1.0, 0.1, 0.05), 20.0),
        Camera::look_along(DVec3::new(0.1, 0.0, 0.0), DVec3::X, 1.0),
        // Among the far triangles, 1e9 units out.
        Camera::look_along(DVec3::new(1e9, 0.0, 0.0), DVec3::X, 60.0),
    ];
    let path = d.path().join("p.csv");
    osw_scene::path::write(&path, &cams).unwrap();
    let run = check_conservative(d.path(), &scene, &path, "deep");
    // Far triangles are exactly visible: the infinite far plane keeps them.
    let visible = std::fs::read_to_string(run.join("exact/exact_leaves.txt")).unwrap();
    let far = visible.split_ascii_whitespace().map(|x| sf.node(x.parse().unwrap()).aabb().min.x as f64).fold(0.0, f64::max);
    assert!(far > 1e6, "the farthest visible leaf is only {far} units away");
}

#[test]
fn a_scene_of_a_million_nodes() {
    let d = tempfile::tempdir().unwrap();
    let scene = d.path().join("big.osw");
    osw_ok(&["build", "--gen", "city", "--triangles", "3000000", "--chunk-triangles", "6", "-o", s(&scene)]);
    let sf = SceneFile::open(&scene).unwrap();
    assert!(sf.nodes().len() >= 1_000_000, "{} nodes", sf.nodes().len());
    let path = camera_path(&scene, "walk", 3);
    let run = d.path().join("run");
    let exact = run.join("exact");
    osw_ok(&["exact", "--scene", s(&scene), "--path", s(&path), "--size", "128x128", "--out", s(&exact)]);
    osw_ok(&["render", "--scene", s(&scene), "--path", s(&path), "--mode", "vfc", "--size", "128x128", "--out", s(&run.join("vfc"))]);
    osw_ok(&["run", "--scene", s(&scene), "--path", s(&path), "--size", "128x128", "--out", s(&run.join("switch"))]);
    let c = compare(&run.join("switch"), &run.join("vfc"), &exact, &run.join("cmp"));
    assert_eq!(c["identical_frames"], 3, "{c}");
    assert_eq!(c["culling_a"]["false_culled_leaves_total"], 0, "{c}");
}
