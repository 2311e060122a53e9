//! Helpers shared by the integration tests: run the `osw` binary, build scenes, and check a
//! scene file's invariants from its tables and geometry (independently of the build code).
#![allow(dead_code)]

use osw_scene::SceneFile;
use osw_scene::format::{NONE, NodeKind};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn osw(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_osw")).args(args).env("OSW_MESH_CACHE", "/nonexistent").output().expect("run osw")
}

/// Runs osw and asserts success; returns stdout.
pub fn osw_ok(args: &[&str]) -> String {
    let out = osw(args);
    assert!(out.status.success(), "osw {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8")
}

/// Runs osw and asserts a clean failure: exit code 1, an `osw: error:` line naming `needle`,
/// and no panic. Returns stderr.
pub fn osw_err(args: &[&str], needle: &str) -> String {
    let out = osw(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "osw {args:?}: expected exit 1, stderr: {err}");
    assert!(err.contains("osw: error:") && err.contains(needle), "osw {args:?}: stderr lacks {needle:?}: {err}");
    assert!(!err.contains("panicked"), "osw {args:?} panicked: {err}");
    err
}

pub fn build_gen(dir: &Path, kind: &str, triangles: u64, seed: u64) -> PathBuf {
    let out = dir.join(format!("{kind}-{triangles}-{seed}.osw"));
    osw_ok(&["build", "--gen", kind, "--triangles", &triangles.to_string(), "--seed", &seed.to_string(), "-o", out.to_str().unwrap()]);
    out
}

/// Every structural invariant of a scene file, checked from the file alone:
/// - ids dense: every node is reached exactly once from the root through children and LODs;
/// - box containment: child boxes in parent boxes, LOD boxes in their owner's box, every
///   vertex of every block in its LOD's box;
/// - error monotonicity: a BVH child's error <= its parent's; a chain's errors strictly rise
///   from 0 at level 0; an HLOD's error >= every child's error;
/// - every leaf triangle reachable: level-0 triangles of all leaves add up to the header's count.
pub fn check_invariants(s: &SceneFile) {
    let nodes = s.nodes();
    let n = nodes.len();
    let mut seen = vec![false; n];
    let mut stack = vec![0u32];
    let mut leaf_triangles = 0u64;
    while let Some(id) = stack.pop() {
        assert!(!seen[id as usize], "node {id} reached twice");
        seen[id as usize] = true;
        let node = nodes[id as usize];
        let b = node.aabb();
        for c in node.children() {
            let child = nodes[c as usize];
            assert!(b.contains(&child.aabb()), "node {id} box does not contain child {c}");
            assert!(child.error <= node.error, "error of child {c} ({}) above parent {id} ({})", child.error, node.error);
            stack.push(c);
        }
        let mut prev: Option<f32> = None;
        for l in node.lods() {
            assert!(!seen[l as usize], "LOD {l} reached twice");
            seen[l as usize] = true;
            let lod = nodes[l as usize];
            assert_eq!(lod.kind(), NodeKind::Lod);
            assert!(b.contains(&lod.aabb()), "LOD {l} box outside owner {id}");
            match prev {
                None if node.kind() == NodeKind::Leaf => assert_eq!(lod.error, 0.0, "level 0 of leaf {id}"),
                None => {
                    let kids = node.children().map(|c| nodes[c as usize].error).fold(0.0, f32::max);
                    assert!(lod.error >= kids && lod.error > 0.0, "HLOD {l} error {} below children's {kids}", lod.error);
                }
                Some(p) => assert!(lod.error > p, "chain of {id} not increasing"),
            }
            prev = Some(lod.error);
            let g = s.geometry(l).expect("geometry passes its checks");
            assert_eq!(g.indices.len() as u32, lod.triangles * 3);
            assert!(!g.indices.is_empty(), "empty LOD {l}");
            assert!(g.positions.iter().all(|p| lod.aabb().contains_point(glam::Vec3::from_array(*p))), "vertex outside LOD {l} box");
        }
        match node.kind() {
            NodeKind::Leaf => {
                assert!(node.lod_count >= 1 && node.child_count == 0);
                assert_eq!(nodes[node.first_lod as usize].triangles, node.triangles);
                assert_ne!(node.object, NONE);
                leaf_triangles += node.triangles as u64;
            }
            NodeKind::Group => assert!(node.child_count >= 2 && node.lod_count <= 1),
            NodeKind::Lod => panic!("LOD {id} in the BVH"),
        }
    }
    assert!(seen.iter().all(|&x| x), "{} nodes unreachable", seen.iter().filter(|x| !**x).count());
    assert_eq!(leaf_triangles, s.header().leaf_triangles as u64);
}
