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
    let differ = differing(&run.join("prev-hybrid"), &copies, 16);
    assert!(differ == 0.0, "{differ} of the pixels differ from the copies'");
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
