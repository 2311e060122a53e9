//! The references the other tests lean on share nothing with what they check:
//! - `osw exact` draws every leaf at full detail and lets the GPU clip (no frustum test, no
//!   traversal), and finds the same visible leaves as the frustum-culled cut it replaced;
//! - with culling deliberately broken (an `osw` built with the `negative-controls` feature into
//!   a target folder of its own; `OSW_FAULT=frustum` pushes a side plane in, `lod-cut` selects
//!   LODs at four times tau), the render checks fail against it: the negative controls a
//!   reference that drew the same cut could not give.

mod common;
use common::*;
use osw_scene::SceneFile;
use std::path::Path;

fn column(csv: &Path, name: &str) -> Vec<u64> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let k = lines.next().unwrap().split(',').position(|c| c == name).unwrap_or_else(|| panic!("{}: no {name}", csv.display()));
    lines.map(|l| l.split(',').nth(k).unwrap().parse().unwrap()).collect()
}

#[test]
fn the_independent_reference_draws_every_leaf_and_agrees_with_the_frustum_cut() {
    let d = tempfile::tempdir().unwrap();
    for kind in ["plant", "city", "teapots"] {
        let scene = build_gen(d.path(), kind, 100_000, 2);
        let path = camera_path(&scene, "walk", 16);
        let full = SceneFile::open(&scene).unwrap().header().leaf_triangles as u64;
        let (ind, cut) = (d.path().join(format!("{kind}-independent")), d.path().join(format!("{kind}-cut")));
        osw_ok(&["exact", "--scene", s(&scene), "--path", s(&path), "--size", SIZE, "--out", s(&ind)]);
        osw_ok(&["exact", "--scene", s(&scene), "--path", s(&path), "--size", SIZE, "--frustum-cut", "--out", s(&cut)]);
        let drawn = column(&ind.join("exact.csv"), "drawn_triangles");
        assert!(drawn.iter().all(|&t| t == full), "{kind}: the independent reference drew {drawn:?}, the scene has {full}");
        assert!(column(&cut.join("exact.csv"), "drawn_triangles").iter().all(|&t| t < full), "{kind}: the walk's frusta cull nothing");
        let leaves = |dir: &Path| std::fs::read_to_string(dir.join("exact_leaves.txt")).unwrap();
        assert_eq!(leaves(&ind), leaves(&cut), "{kind}: the two references see different leaves");
        assert!(column(&ind.join("exact.csv"), "visible_leaves").iter().all(|&n| n > 0), "{kind}: a frame sees nothing");
    }
}

/// `osw` with the faults of osw_cull's `fault` module: built with the `negative-controls`
/// feature into `target/negative`, so that no other build has them (Cargo would unify the
/// feature into the `osw` the other tests run, were it built in the same folder).
fn broken_osw() -> &'static Path {
    static BUILT: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    BUILT.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let target = root.join("target/negative");
        let status = std::process::Command::new(env!("CARGO"))
            .current_dir(&root)
            .args(["build", "--release", "--locked", "-p", "osw", "--bin", "osw", "--features", "negative-controls", "--target-dir"])
            .arg(&target)
            .status()
            .unwrap();
        assert!(status.success(), "building the negative control's osw failed");
        target.join("release/osw")
    })
}

/// The negative control's `osw` with `fault` on.
fn osw_broken(fault: &str, args: &[&str]) {
    let out = std::process::Command::new(broken_osw()).args(args).env("OSW_FAULT", fault).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

/// The `osw` the other tests run (and a user builds) ignores the faults' environment.
#[test]
fn the_environment_cannot_break_culling() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 100_000, 2);
    let path = camera_path(&scene, "walk", 16);
    render(&scene, &path, ("vfc", "exact"), "1", &d.path().join("vfc"));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_osw"))
        .args(["render", "--scene", s(&scene), "--path", s(&path), "--mode", "vfc", "--tau", "1", "--size", SIZE, "--out"])
        .arg(d.path().join("vfc-env"))
        .env("OSW_FAULT", "frustum,lod-cut")
        .env("OSW_BROKEN_FRUSTUM", "1")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let pvs = |run: &str| std::fs::read_to_string(d.path().join(run).join("pvs.txt")).unwrap();
    assert_eq!(pvs("vfc"), pvs("vfc-env"), "the environment changed what vfc culls");
}

/// LODs selected too coarse in osw_cull are caught at tau 1 by the independent reference,
/// which picks each node's level from the node table alone; the same runs without the fault
/// draw every visible LOD.
#[test]
fn a_broken_lod_cut_is_caught_by_the_independent_reference_at_tau_1() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 100_000, 2);
    let path = camera_path(&scene, "walk", 16);
    let (exact, exact1) = (d.path().join("exact"), d.path().join("exact1"));
    osw_ok(&["exact", "--scene", s(&scene), "--path", s(&path), "--size", SIZE, "--out", s(&exact)]);
    osw_ok(&["exact", "--scene", s(&scene), "--path", s(&path), "--size", SIZE, "--tau", "1", "--out", s(&exact1)]);
    render(&scene, &path, ("vfc", "exact"), "0", &d.path().join("vfc"));
    let not_drawn = |run: &Path, label: &str| {
        let out = d.path().join(format!("cmp-{label}"));
        let c = {
            osw_ok(&[
                "compare",
                "--a",
                s(run),
                "--b",
                s(&d.path().join("vfc")),
                "--exact",
                s(&exact),
                "--exact-lod",
                s(&exact1),
                "--out",
                s(&out),
            ]);
            serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap()
        };
        c["culling_a"]["lod_not_drawn_total"].as_u64().unwrap_or_else(|| panic!("{label}: no lod_not_drawn_total: {c}"))
    };
    for (mode, hc) in [("vfc", "exact"), ("prev", "hybrid")] {
        let run = d.path().join(format!("{mode}-1"));
        render(&scene, &path, (mode, hc), "1", &run);
        assert_eq!(not_drawn(&run, mode), 0, "{mode} at tau 1 left visible LODs undrawn");
        let broken = d.path().join(format!("broken-{mode}-1"));
        osw_broken("lod-cut", &render_args(&scene, &path, (mode, hc), "1", &broken));
        assert!(not_drawn(&broken, &format!("broken-{mode}")) > 0, "broken {mode}: its coarse LODs went unseen");
    }
}

#[test]
fn a_broken_frustum_is_caught_by_the_independent_reference() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 100_000, 2);
    let path = camera_path(&scene, "walk", 16);
    let exact = d.path().join("exact");
    osw_ok(&["exact", "--scene", s(&scene), "--path", s(&path), "--size", SIZE, "--out", s(&exact)]);
    let broken_cut = d.path().join("exact-broken-cut");
    osw_broken("frustum", &["exact", "--scene", s(&scene), "--path", s(&path), "--size", SIZE, "--frustum-cut", "--out", s(&broken_cut)]);
    render(&scene, &path, ("vfc", "exact"), "0", &d.path().join("vfc"));
    for (mode, hc) in [("vfc", "exact"), ("prev", "hybrid")] {
        let run = d.path().join(format!("broken-{mode}"));
        osw_broken("frustum", &render_args(&scene, &path, (mode, hc), "0", &run));
        let c = compare(&run, &d.path().join("vfc"), &exact, &d.path().join(format!("cmp-{mode}")));
        assert!(c["culling_a"]["false_culled_leaves_total"].as_u64().unwrap() > 0, "broken {mode}: no false culling seen: {c}");
        assert!(c["identical_frames"].as_u64().unwrap() < 16, "broken {mode}: frames equal the intact vfc's: {c}");
        // The old reference, made with the same broken frustum, sees nothing wrong.
        let c = compare(&run, &d.path().join("vfc"), &broken_cut, &d.path().join(format!("cmp-cut-{mode}")));
        assert_eq!(c["culling_a"]["false_culled_leaves_total"], 0, "broken {mode} against the broken cut: {c}");
    }
}
