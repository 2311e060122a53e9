//! Smoke runs of the scripts a user runs (README), on a tiny generated plant and a few frames,
//! with the binaries this test run built (OSW_BIN): each must finish and leave the files it
//! promises, with numbers in them. `scripts/fuzz.sh` is checked for its help and its target
//! list (a real run builds cargo-fuzz and a sanitizer build, minutes: not for every test run);
//! `scripts/walk-input.sh` is sourced by bandwidth.sh and latency.sh, `scripts/tools.sh` by all
//! of these.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts").join(name)
}

/// Runs `scripts/NAME args` with a tiny plant; returns stdout.
fn run_script(name: &str, args: &[&str], env: &[(&str, &str)]) -> String {
    let bin = Path::new(env!("CARGO_BIN_EXE_osw")).parent().unwrap();
    let out = Command::new("bash")
        .arg(script(name))
        .args(args)
        .env("OSW_BIN", bin)
        .env("OSW_MESH_CACHE", "/nonexistent")
        .env("TRIANGLES", "20000")
        .env("FRAMES", "6")
        .envs(env.iter().copied())
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{name} {args:?} failed: {stdout}\n{stderr}");
    stdout
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))).unwrap()
}

#[test]
fn demo_runs_the_switch_and_reports_its_error() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("demo");
    run_script("demo.sh", &["--out", s(&out), "--size", "64x64"], &[]);
    assert_eq!(std::fs::read_dir(out.join("switch/frames")).unwrap().count(), 6);
    let c = json(&out.join("report/compare.json"));
    assert_eq!(c["frames"], 6, "{c}");
    assert_eq!(c["culling_b"]["false_culled_leaves_total"], 0, "vfc against exact visibility: {c}");
    assert!(std::fs::read_to_string(out.join("report.txt")).unwrap().contains("compare"));
}

#[test]
fn bandwidth_and_latency_measure_a_loopback_run() {
    let d = tempfile::tempdir().unwrap();
    let bw = d.path().join("bw");
    run_script("bandwidth.sh", &["--size", "64x64", "--out", s(&bw)], &[]);
    let b = json(&bw.join("bandwidth.json"));
    assert!(b.as_object().is_some_and(|o| !o.is_empty()), "{b}");
    assert!(bw.join("bandwidth_ids.png").exists() && bw.join("bandwidth.csv").exists());
    let lat = d.path().join("lat");
    run_script("latency.sh", &["--size", "64x64", "--out", s(&lat)], &[]);
    assert!(lat.join("latency.json").exists() && lat.join("latency.md").exists() && lat.join("latency.png").exists());
}

#[test]
fn clusters_tabulates_both_settings_against_exact_visibility() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("clusters");
    run_script("clusters.sh", &["--triangles", "20000,30000", "--frames", "4", "--size", "64x64", "--out", s(&out)], &[]);
    for run in ["prev-small", "prev-large", "switch-large"] {
        let c = json(&out.join(format!("cmp-{run}/compare.json")));
        let drawn = c["culling_a"]["drawn_exact_triangles_ratio_mean"].as_f64().unwrap();
        let floor = c["cluster_exact_triangles_ratio_mean"].as_f64().unwrap();
        assert!(drawn > 0.0 && floor >= 1.0, "{run}: {c}");
        for floor in ["visible_draw_ms_median", "visible_cluster_draw_ms_median"] {
            assert!(c[floor].as_f64().is_some_and(|ms| ms > 0.0), "{run}: {c}");
        }
        // At tau 5, against what is visible at that tau (the rest is LOD error).
        let missed = if run == "prev-small" { "false_culled_leaves_total" } else { "lod_false_culled_total" };
        assert_eq!(c["culling_a"][missed], 0, "{run}: {c}");
    }
    for run in ["prev-small", "vfc-large", "prev-large", "switch-large"] {
        let t = json(&out.join(format!("{run}/cpu.json")));
        assert!(t["cpu_s"].as_f64().unwrap() > 0.0 && t["wall_s"].as_f64().unwrap() > 0.0, "{run}: {t}");
    }
    let table = std::fs::read_to_string(out.join("clusters.md")).unwrap();
    assert_eq!(table.lines().filter(|l| l.starts_with('|')).count(), 6, "{table}");
    assert!(table.lines().any(|l| l.contains("allows it at most")), "{table}");
}

/// The soak's short version: every fault once (nodes killed and restarted, the nodes' link cut
/// and made lossy, the display restarted, its link to node a cut) and no frame lost, none differing from prev's, V(i)
/// prev's on every frame not marked degraded, each process's memory reported per lap and
/// plotted.
#[test]
fn soak_survives_every_fault_with_prevs_frames() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("soak");
    run_script("soak.sh", &["--short", "--out", s(&out)], &[("TRIANGLES", "200000"), ("FRAMES", "60")]);
    let table = std::fs::read_to_string(out.join("soak.csv")).unwrap();
    let rows: Vec<Vec<&str>> = table.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 8, "{table}");
    let faults: std::collections::HashSet<&str> = rows.iter().map(|r| r[1]).filter(|f| *f != "none").collect();
    assert_eq!(faults.len(), 6, "not every fault ran: {table}");
    for r in &rows {
        let (lost, differing, vi, culled, beyond) = (r[2], r[3], r[4], r[5], r[6]);
        assert_eq!(
            [lost, differing, vi, beyond],
            ["0"; 4],
            "lap {}: frames lost, differing, V(i) differing, culled beyond prev's: {table}",
            r[0]
        );
        assert_eq!(culled, "0", "lap {}: leaves culled: {table}", r[0]);
        assert!(r[10..13].iter().all(|kb| kb.parse::<u64>().unwrap() > 1024), "lap {}: memory not read: {table}", r[0]);
    }
    assert!(out.join("soak.png").exists() && out.join("soak.svg").exists());
}

#[test]
fn scale_sweeps_sizes_and_resumes() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("scale");
    let args = [
        "--sizes",
        "20K,40K",
        "--walks",
        "2",
        "--taus",
        "1",
        "--modes",
        "chc,prev,switch",
        "--frames",
        "4",
        "--size",
        "64x64",
        "--out",
        s(&out),
    ];
    run_script("scale.sh", &args, &[]);
    let v = json(&out.join("scale.json"));
    let runs = v["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 12, "{v}");
    // Two walks of each size, not one walk twice.
    let first = |w: u64| runs.iter().find(|r| r["walk"] == w && r["mode"] == "chc").unwrap()["hc_tests_mean"].as_f64().unwrap();
    assert_ne!(first(1), first(2), "{v}");
    for r in runs {
        assert!(r["error"].is_null() && r["frame_ms_median"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["peak_rss_kb"].as_object().unwrap().values().all(|kb| kb.as_u64().unwrap() > 0), "{r}");
        // Every run's CPU time, the switch's summed over its three processes; its retests
        // from its nodes' statistics, a part of the tests the display counted.
        assert!(r["cpu_ms_median"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["hc_retests_mean"].as_f64().is_some_and(|n| n >= 0.0), "{r}");
        assert!(r["hc_first_pass_tests_mean"].as_f64().is_some_and(|n| n >= 0.0), "{r}");
    }
    assert_eq!(runs.iter().filter(|r| r["mode"] == "switch").map(|r| r["peak_rss_kb"].as_object().unwrap().len()).sum::<usize>(), 12);
    // Each size and mode over its walks, its ratios to CHC walk by walk.
    let over = v["over_walks"].as_array().unwrap();
    assert_eq!(over.len(), 6, "{v}");
    for o in over {
        assert_eq!(o["walks"], 2, "{o}");
        assert!(o["frame_ms_worst"].as_f64().unwrap() >= o["frame_ms_median"].as_f64().unwrap(), "{o}");
        assert!(o["first_pass_to_chc_worst"].as_f64().unwrap() >= o["first_pass_to_chc"].as_f64().unwrap(), "{o}");
    }
    for sc in v["scenes"].as_array().unwrap() {
        assert!(sc["build_peak_rss_kb"].as_u64().unwrap() > 0 && sc["file_bytes"].as_u64().unwrap() > 0, "{sc}");
    }
    assert!(out.join("scale.png").exists() && out.join("scale.md").exists());
    // A second sweep finds every run there and repeats none of them.
    let stamp = std::fs::metadata(out.join("runs/20K/walk-2/prev-tau1/summary.json")).unwrap().modified().unwrap();
    run_script("scale.sh", &args, &[]);
    assert_eq!(std::fs::metadata(out.join("runs/20K/walk-2/prev-tau1/summary.json")).unwrap().modified().unwrap(), stamp);
}

#[test]
fn fuzz_names_every_target() {
    let help = Command::new("bash").arg(script("fuzz.sh")).arg("--help").output().unwrap();
    assert!(help.status.success() && String::from_utf8_lossy(&help.stdout).contains("--runs"));
    let text = std::fs::read_to_string(script("fuzz.sh")).unwrap();
    let listed = text.lines().find(|l| l.contains("|| targets=(")).unwrap();
    let harness = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/libfuzzer/Cargo.toml")).unwrap();
    // The targets as the fuzz crate lists them: `("name", module::run),` lines of TARGETS.
    let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/src/lib.rs")).unwrap();
    let names: Vec<&str> = lib.lines().filter_map(|l| l.trim().strip_prefix("(\"").and_then(|r| r.split('"').next())).collect();
    assert!(names.len() >= 7, "{names:?}");
    for name in names {
        assert!(listed.contains(name), "fuzz.sh does not run {name}");
        assert!(harness.contains(&format!("name = \"{name}\"")), "the cargo-fuzz harness has no {name}");
    }
}

#[test]
fn real_models_tabulates_every_shared_model_against_vfc_and_exact_visibility() {
    let Some(dir) = real_models_dir("real_models_tabulates_every_shared_model_against_vfc_and_exact_visibility") else { return };
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("rm");
    run_script("real-models.sh", &["--frames", "4", "--size", "64x64", "--out", s(&out)], &[("OSW_MODELS", s(&dir))]);
    let table = std::fs::read_to_string(out.join("real-models.md")).unwrap();
    let rows: Vec<Vec<&str>> = table.lines().skip(2).map(|l| l.split('|').map(str::trim).collect()).collect();
    let models = std::fs::read_dir(&dir).unwrap().filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "glb")).count();
    // A row per model, tau (0, 1) and mode (vfc, prev, the switch).
    assert_eq!(rows.len(), models * 6, "{table}");
    for r in rows.iter().filter(|r| r[3] == "0") {
        let (same, frames) = r[7].split_once(" of ").unwrap_or_else(|| panic!("{table}"));
        assert_eq!(same, frames, "{r:?}: frames differ from vfc's");
        assert_eq!(r[8], "0", "{r:?}: false culling");
        assert_eq!(r[9], "0", "{r:?}: pixels drawn differently from the same nodes");
    }
}

/// `scripts/gpu-bundle.sh`: a folder of at most 50 MiB whose run script, with no cargo and no
/// repository, runs the sweep and a switch walk (here `--quick`, on lavapipe with
/// `--allow-cpu`) into at most 8 files naming the adapter, and refuses the CPU adapter without
/// that flag.
#[test]
fn the_gpu_bundle_runs_without_the_repository_and_refuses_a_cpu_by_default() {
    let d = tempfile::tempdir().unwrap();
    let bundle = d.path().join("bundle");
    run_script("gpu-bundle.sh", &["--out", s(&bundle)], &[]);
    let bytes: u64 = walk_files(&bundle).iter().map(|p| std::fs::metadata(p).unwrap().len()).sum();
    assert!(bytes <= 50 << 20, "{bytes} bytes");
    let results = d.path().join("results");
    let run = |args: &[&str]| {
        Command::new("bash")
            .arg(bundle.join("run.sh"))
            .args(args)
            .args(["--results", s(&results), "--work", s(&d.path().join("work"))])
            .current_dir(d.path())
            .env_remove("OSW_BIN")
            .env("PATH", "/usr/bin:/bin")
            .output()
            .unwrap()
    };
    let refused = run(&["--quick"]);
    assert_eq!(refused.status.code(), Some(3), "{}", String::from_utf8_lossy(&refused.stderr));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--allow-cpu"));
    let ok = run(&["--quick", "--allow-cpu"]);
    assert!(ok.status.success(), "{}\n{}", String::from_utf8_lossy(&ok.stdout), String::from_utf8_lossy(&ok.stderr));
    let files = walk_files(&results);
    assert!(files.len() <= 8, "{files:?}");
    assert!(std::fs::read_to_string(results.join("adapter.txt")).unwrap().contains("device_type: Cpu"));
    let scale = json(&results.join("scale.json"));
    let text = scale.to_string();
    for mode in ["vfc", "chc", "prev", "switch"] {
        assert!(text.contains(&format!("\"{mode}\"")), "{mode} missing: {text}");
    }
    let sw = json(&results.join("switch-summary.json"));
    assert_eq!(sw["frames"], 10, "{sw}");
}

fn walk_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() { out.extend(walk_files(&p)) } else { out.push(p) }
    }
    out
}
