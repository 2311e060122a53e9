//! `osw report`: every mode at every tau lands in report.md and report.json with the figures
//! of its own run (checked against the run's stats.csv and against exact visibility), no mode
//! culls a visible leaf at tau 0, the plot is drawn, and a second report reuses the runs.

mod common;
use common::*;
use osw_render::results::Report;
use std::path::Path;

/// Mean of column `name` of a CSV file.
fn csv_mean(file: &Path, name: &str) -> f64 {
    let v = csv_column(file, name);
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn report_covers_every_mode_and_tau_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = build_gen(dir.path(), "plant", 60_000, 3);
    let path = camera_path(&scene, "walk", 8);
    let out = dir.path().join("report");
    // ovc, prev and the switch also with adaptive culling at a threshold that drops every box
    // they test exactly.
    let args =
        ["report", "--scene", s(&scene), "--path", s(&path), "--size", "128x128", "--taus", "0,8", "--adaptive", "0,1e9", "--out", s(&out)];
    osw_ok(&args);

    let report: Report = osw_render::results::read_json(&out.join("report.json")).unwrap();
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let runs = &report.runs;
    let modes = ["vfc", "sw", "chc", "hzb", "prev", "switch", "ovc"];
    assert_eq!(runs.len(), modes.len() * 2 + 6, "every mode at both taus, and ovc, prev and the switch adaptive at both");
    for mode in modes {
        assert!(md.contains(&format!("| {mode} fps")), "report.md lacks {mode} in table 1");
        for tau in [0.0, 8.0] {
            let e = runs.iter().find(|e| e.mode.name() == mode && e.tau == tau).unwrap_or_else(|| panic!("no {mode} at tau {tau}"));
            assert!(e.error.is_none(), "{mode} tau {tau} failed: {e:?}");
            assert!(md.contains(&format!("| {mode} | {tau} | ")), "report.md lacks the row of {mode} at tau {tau}");
            let run = out.join("runs").join(format!("{mode}-tau{tau}"));
            let drawn = csv_mean(&run.join("stats.csv"), "triangles_drawn");
            assert!((e.triangles_drawn_mean - drawn).abs() < 1e-6 * drawn.max(1.0), "{mode} tau {tau}: {e:?}");
            if tau == 0.0 {
                // Conservative culling at full detail: the image of vfc, no visible leaf missed.
                assert_eq!(e.false_culled_leaves_total, 0, "{mode}: {e:?}");
                assert_eq!(e.identical_frames, 8, "{mode}: {e:?}");
            } else {
                // Coarser LODs change pixels; vfc at tau 8 draws fewer triangles than at tau 0.
                assert!(e.differing_fraction_mean > 0.0, "{mode}: {e:?}");
                eprintln!(
                    "{mode} tau {tau}: false-culled {} at tau, {} at full detail",
                    e.false_culled_at_tau_total, e.false_culled_leaves_total
                );
                // The switch culls conservatively for the scene as drawn at its tau.
                if mode == "switch" || mode == "prev" {
                    assert_eq!(e.false_culled_at_tau_total, 0, "{mode}: {e:?}");
                }
            }
            assert!(!run.join("frames").exists(), "{mode} tau {tau}: frames kept without --keep-frames");
            // The switch's traffic, as its display counted it; no traffic for the others.
            if mode == "switch" {
                let ids = csv_mean(&run.join("stats.csv"), "ids_sent");
                assert!((e.traffic.as_ref().unwrap().ids_sent_mean - ids).abs() < 1e-9, "{e:?}");
                let row = format!("| {tau} | {ids:.1} | {:.1} |", csv_mean(&run.join("stats.csv"), "ids_full"));
                assert!(md.contains(&row), "report.md lacks the switch's traffic row {row}");
            } else {
                assert!(e.traffic.is_none(), "{mode}: {e:?}");
            }
        }
    }
    // Adaptive culling buys triangles with error, and the report shows both.
    for (mode, tau) in [("ovc", 0.0), ("ovc", 8.0), ("prev", 0.0), ("prev", 8.0), ("switch", 0.0), ("switch", 8.0)] {
        let find = |adaptive: f64| runs.iter().find(|e| e.mode.name() == mode && e.tau == tau && e.adaptive == adaptive);
        let (e, c) = (find(1e9).expect("adaptive run"), find(0.0).unwrap());
        assert!(e.error.is_none(), "{e:?}");
        assert!(e.triangles_drawn_mean < c.triangles_drawn_mean, "{mode}: {e:?} vs {c:?}");
        assert!(e.false_culled_at_tau_total > 0, "approximate culling misses visible nodes: {e:?}");
        assert!(md.contains(&format!("| {mode} (adaptive 1000000000) | {tau} | ")), "report.md lacks {mode}'s adaptive row at tau {tau}");
        if mode != "switch" {
            let run = out.join("runs").join(format!("{mode}-tau{tau}-adaptive1000000000"));
            let summary = render_summary(&run);
            assert!(summary.adaptive_culled_mean > 0.0, "{summary:?}");
        }
    }
    assert!(md.contains("Bartz 1999, table 2"), "report.md lacks table 2's form");
    assert!(std::fs::read_to_string(out.join("error_vs_time.svg")).unwrap().contains("Pareto front"), "no Pareto front in the plot");
    // PVS/exact against the exact run computed by `osw exact`: never below 1 at tau 0.
    let exact_leaves = csv_mean(&out.join("exact/exact.csv"), "visible_leaves");
    assert!(out.join("exact-tau8/exact_leaves.txt").exists(), "no exact visibility at tau 8");
    assert!((report.exact_leaves_mean - exact_leaves).abs() < 1e-9);
    for e in runs.iter().filter(|e| e.tau == 0.0 && e.adaptive == 0.0) {
        assert!(e.pvs_exact_leaves >= 1.0, "{e:?}");
    }
    let (w, h, px) = osw_render::output::read_png(&out.join("error_vs_time.png")).unwrap();
    assert!(w >= 640 && h >= 400 && px.chunks(4).any(|p| p[..3] != px[..3]), "blank plot");
    assert!(std::fs::read_to_string(out.join("error_vs_time.svg")).unwrap().contains("<svg"));

    // A second report on the same input reuses every run.
    let stamp = |m: &str| std::fs::metadata(out.join("runs").join(m).join("summary.json")).unwrap().modified().unwrap();
    let before = stamp("sw-tau0");
    osw_ok(&args);
    assert_eq!(stamp("sw-tau0"), before, "the second report ran sw again");
}

#[test]
fn report_refuses_unknown_modes_and_bad_taus() {
    let dir = tempfile::tempdir().unwrap();
    let scene = build_gen(dir.path(), "plant", 20_000, 1);
    let path = camera_path(&scene, "walk", 2);
    let out = dir.path().join("r");
    let base = ["report", "--scene", s(&scene), "--path", s(&path), "--out", s(&out)];
    // An unknown mode is an argument error (exit 2) naming it and the modes.
    let bad = osw(&[&base[..], &["--modes", "vfc,gigawalk"]].concat());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{err}");
    assert!(err.contains("gigawalk") && err.contains("vfc, sw, chc, hzb, prev, ovc, switch"), "{err}");
    osw_err(&[&base[..], &["--taus", "0,-1"]].concat(), "-1");
    osw_err(&[&base[..], &["--adaptive", "0,NaN"]].concat(), "--adaptive");
    assert!(!out.join("runs").exists(), "nothing runs when the arguments are wrong");
}
