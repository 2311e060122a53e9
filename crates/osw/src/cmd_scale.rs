//! `osw scale`: a frame's cost against the model's size. Builds the generated plant at each
//! size, makes walks of the same kind through each (seeds 1..N), runs every mode at every tau
//! on every walk (child `osw render`, the switch a child `osw run`) and writes scale.json,
//! scale.md and scale.png (`crate::scale_report`): a frame's cost depends on what the walk sees,
//! so each figure is also given as its median over the walks and its worst walk.
//!
//! Scenes, walks and runs already in DIR for the same input are used again, so an interrupted
//! sweep resumes where it stopped.

use crate::cmd_report::osw;
use crate::scale_report::{self, Row, Scene, Sweep, label};
use anyhow::{Context, bail};
use osw_render::results::{self, DisplayFrame, Duty, Input, NodeFrame, Summary};
use osw_render::stats::{mean, quantile};
use osw_render::{FrameStats, Mode};
use osw_scene::build::BuildReport;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Plant sizes in triangles (K, M and B suffixes: 2M = 2,000,000).
    #[arg(long, value_delimiter = ',', default_value = "2M,20M,100M", value_parser = parse_size)]
    sizes: Vec<u64>,
    /// Add the billion-triangle plant (1B) to the sizes.
    #[arg(long)]
    huge: bool,
    /// The instanced plant (`osw build --gen plant --instanced`: catalogue parts stored once),
    /// files plant-instanced-SIZE.osw; sizes count the triangles as drawn (10B builds in
    /// minutes).
    #[arg(long)]
    instanced: bool,
    /// Pixels-of-error thresholds to run each mode at.
    #[arg(long, value_delimiter = ',', default_value = "1,5")]
    taus: Vec<f64>,
    /// Modes: vfc, sw, chc, hzb, prev, ovc (single process) and switch (`osw run`).
    #[arg(long, value_delimiter = ',', default_value = "vfc,chc,hzb,prev,switch")]
    modes: Vec<Mode>,
    /// Frames of each walk.
    #[arg(long, default_value_t = 100)]
    frames: u32,
    /// Walks per size (seeds 1..N): scale.md gives each figure per walk, its median over the
    /// walks and the worst walk.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    walks: u32,
    /// Cost-adaptive culling (osw_cull::payoff) in prev and the switch: frames where
    /// occlusion culling last cost more than it saved are frustum culled only. Off by default,
    /// so that every mode culls every frame, as CHC's paper runs it; runs go to
    /// runs/SIZE/MODE-tauT-adaptive.
    #[arg(long)]
    cost_adaptive: bool,
    /// Image size of every run.
    #[arg(long, default_value = "1024x1024")]
    size: String,
    /// Output directory: scale.json, scale.md, scale.png/.svg; plant-SIZE.osw and its walks;
    /// runs/SIZE/walk-SEED/MODE-tauT/ (each run's summary and statistics).
    #[arg(long)]
    out: PathBuf,
}

fn parse_size(s: &str) -> Result<u64, String> {
    let (digits, unit) = match s.trim().char_indices().last() {
        Some((k, c)) if c.is_ascii_alphabetic() => (&s.trim()[..k], c.to_ascii_uppercase()),
        _ => (s.trim(), ' '),
    };
    let scale = match unit {
        ' ' => 1,
        'K' => 1_000,
        'M' => 1_000_000,
        'B' | 'G' => 1_000_000_000,
        _ => return Err(format!("{s:?}: a triangle count such as 2000000, 2M or 1B")),
    };
    let n: f64 = digits.parse().map_err(|_| format!("{s:?}: a triangle count such as 2000000, 2M or 1B"))?;
    match n * scale as f64 {
        t if (1.0..=1e10).contains(&t) => Ok(t as u64),
        _ => Err(format!("{s:?}: between 1 and 10B triangles")),
    }
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// The plant of `triangles` in `out`, built unless there from an earlier sweep.
fn scene(out: &Path, triangles: u64, instanced: bool) -> anyhow::Result<(Scene, PathBuf)> {
    let name = label(triangles);
    let file = out.join(format!("plant-{}{name}.osw", if instanced { "instanced-" } else { "" }));
    let report = file.with_extension("build.json");
    let timing = file.with_extension("seconds");
    if !(file.exists() && report.exists() && timing.exists()) {
        let t = Instant::now();
        let args = ["build", "--gen", "plant", "--triangles", &triangles.to_string(), "--seed", "1", "-o", &file.display().to_string()];
        let mut args = strings(&args);
        if instanced {
            args.push("--instanced".into());
        }
        osw(&args, &file.with_extension("build.log"))?;
        std::fs::write(&timing, t.elapsed().as_secs_f64().to_string())?;
    }
    let r: BuildReport = results::read_json(&report)?;
    let build_seconds = std::fs::read_to_string(&timing)?.trim().parse().with_context(|| format!("{}: not seconds", timing.display()))?;
    let s = Scene { triangles, label: name, build_seconds, build_peak_rss_kb: r.peak_rss_kb, file_bytes: std::fs::metadata(&file)?.len() };
    Ok((s, file))
}

/// Walk `seed` of `frames` frames through the scene in `file`, made unless there.
fn walk(file: &Path, frames: u32, seed: u32) -> anyhow::Result<PathBuf> {
    let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("plant");
    let walk = file.with_file_name(format!("{stem}-walk-{frames}-seed{seed}.csv"));
    if !walk.exists() {
        let args = ["path", "--scene", &file.display().to_string(), "--kind", "walk", "--frames", &frames.to_string()];
        let mut args = strings(&args);
        args.extend(["--seed".into(), seed.to_string(), "-o".into(), walk.display().to_string()]);
        osw(&args, &walk.with_extension("log"))?;
    }
    Ok(walk)
}

/// One mode at one tau into `dir`, unless a run of the same scene, walk, tau and size is there.
fn run_one(scene: &Path, walk: &Path, size: &str, mode: Mode, tau: f64, adaptive: bool, dir: &Path) -> anyhow::Result<Summary> {
    let hash = osw_scene::format::hash_hex(osw_scene::SceneFile::open(scene)?.content_hash());
    let (w, h) = crate::walk_args::parse_size(size).map_err(anyhow::Error::msg)?;
    let input = Input { scene_hash: hash, path: walk.display().to_string(), width: w, height: h };
    if let Ok(s) = Summary::read(dir)
        && Input::of(&s) == input
        && s.tau == tau
        && (adaptive || s.cull_skipped_frames == 0)
    {
        return Ok(s);
    }
    std::fs::create_dir_all(dir)?;
    let _ = std::fs::remove_file(dir.join("summary.json"));
    let mut args = match mode {
        Mode::Switch => strings(&["run"]),
        m => strings(&["render", "--mode", m.name()]),
    };
    args.extend(strings(&["--scene", &scene.display().to_string(), "--path", &walk.display().to_string(), "--size", size]));
    args.extend(strings(&["--tau", &tau.to_string(), "--no-frames", "--out", &dir.display().to_string()]));
    // CHC as CHC runs it: every frame culled (cost-adaptive culling is osw's).
    if mode == Mode::Chc || !adaptive {
        args.push("--always-cull".into());
    }
    osw(&args, &dir.join("run.log"))?;
    Ok(Summary::read(dir)?)
}

fn row(triangles: u64, walk: u32, tau: f64, dir: &Path, s: &Summary) -> anyhow::Result<Row> {
    let mut peak = BTreeMap::new();
    let (retests, cpu_ms) = match s.render() {
        Some(r) => {
            peak.insert("render".into(), r.peak_rss_kb);
            let frames: Vec<FrameStats> = results::csv::read(&dir.join("stats.csv"))?;
            (r.retests_mean, quantile(&frames.iter().map(|f| f.cpu_ms).collect::<Vec<_>>(), 0.5))
        }
        // The switch's processes: the most each sampled over its frames; the CPU time of
        // each frame, the display's and both nodes' (HC of the frame and OR for the next) summed;
        // the retests of the frames each was HC.
        None => {
            let most = |rss: Option<u64>, file: &str| rss.with_context(|| format!("{}: no frames", dir.join(file).display()));
            let display: Vec<DisplayFrame> = results::csv::read(&dir.join("stats.csv"))?;
            peak.insert("display".into(), most(display.iter().map(|f| f.rss_kb).max(), "stats.csv")?);
            let mut cpu: BTreeMap<u64, f64> = display.iter().map(|f| (f.frame, f.cpu_ms)).collect();
            let mut hc = Vec::new();
            for (k, file) in [("node_a", "node-a.csv"), ("node_b", "node-b.csv")] {
                let node: Vec<NodeFrame> = results::csv::read(&dir.join(file))?;
                peak.insert(k.into(), most(node.iter().map(|f| f.rss_kb).max(), file)?);
                for f in &node {
                    cpu.entry(f.frame).and_modify(|ms| *ms += f.cpu_ms);
                }
                hc.extend(node.iter().filter(|f| f.duty != Duty::Or).map(|f| f.retests as f64));
            }
            (mean(hc), quantile(&cpu.into_values().collect::<Vec<_>>(), 0.5))
        }
    };
    Ok(Row {
        triangles,
        walk,
        mode: s.mode,
        tau,
        frame_ms_median: s.frame_ms_median,
        frame_ms_p95: s.frame_ms_p95,
        hc_tests_mean: s.tests_mean,
        hc_retests_mean: retests,
        hc_first_pass_tests_mean: s.tests_mean - retests,
        hc_tests_where: s.render().map(|r| [r.tests_front_mean, r.tests_siblings_mean, r.tests_new_mean]),
        hc_ms_median: s.hc_ms_median,
        or_ms_median: s.or_ms_median().with_context(|| format!("{}: no OR time (no node statistics with OR frames)", dir.display()))?,
        rvg_ms_median: s.rvg_ms_median,
        triangles_drawn_mean: s.triangles_drawn_mean,
        pvs_nodes_mean: s.pvs_nodes_mean,
        cpu_ms_median: cpu_ms,
        peak_rss_kb: peak,
        error: None,
    })
}

pub fn run(mut a: Args) -> anyhow::Result<()> {
    if let Some(t) = a.taus.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
        bail!("--taus: {t} is not a pixel error (a finite number ≥ 0)");
    }
    if a.huge && !a.sizes.contains(&1_000_000_000) {
        a.sizes.push(1_000_000_000);
    }
    a.sizes.sort_unstable();
    a.sizes.dedup();
    std::fs::create_dir_all(&a.out)?;
    // Runs are matched by their walk's path: one spelling of DIR, however it was given.
    a.out = std::fs::canonicalize(&a.out).with_context(|| format!("--out {}", a.out.display()))?;
    let steps = a.sizes.len() * (1 + a.walks as usize * (1 + a.modes.len() * a.taus.len()));
    let bar = crate::progress::steps(steps as u64, "scale");
    let (mut scenes, mut rows) = (Vec::new(), Vec::new());
    for &n in &a.sizes {
        bar.set_message(format!("plant {}", label(n)));
        let (s, file) = scene(&a.out, n, a.instanced).with_context(|| format!("the {}-triangle plant", label(n)))?;
        bar.inc(1);
        for seed in 1..=a.walks {
            bar.set_message(format!("{} walk {seed}", s.label));
            let walk = walk(&file, a.frames, seed).with_context(|| format!("walk {seed} through the {} plant", s.label))?;
            bar.inc(1);
            for &tau in &a.taus {
                for &mode in &a.modes {
                    bar.set_message(format!("{} walk {seed} {mode} tau {tau}", s.label));
                    let name = format!("{mode}-tau{tau}{}", if a.cost_adaptive { "-adaptive" } else { "" });
                    let dir = a.out.join("runs").join(&s.label).join(format!("walk-{seed}")).join(name);
                    let r = run_one(&file, &walk, &a.size, mode, tau, a.cost_adaptive, &dir)
                        .and_then(|v| row(n, seed, tau, &dir, &v))
                        .unwrap_or_else(|e| {
                            bar.println(format!("osw: {} walk {seed} {mode} at tau {tau} failed: {e:#}", s.label));
                            Row { triangles: n, walk: seed, mode, tau, error: Some(format!("{e:#}")), ..Default::default() }
                        });
                    rows.push(r);
                    bar.inc(1);
                }
            }
        }
        scenes.push(s);
    }
    bar.finish_and_clear();
    let over_walks = scale_report::over_walks(&rows);
    let sweep = Sweep { frames: a.frames, walks: a.walks, size: a.size.clone(), scenes, runs: rows, over_walks };
    std::fs::write(a.out.join("scale.json"), serde_json::to_string_pretty(&sweep)?)?;
    let report = scale_report::Report { sweep: &sweep, taus: &a.taus, modes: &a.modes, cost_adaptive: a.cost_adaptive };
    std::fs::write(a.out.join("scale.md"), report.markdown())?;
    crate::plot::write_log_log(&report.charts(), &a.out.join("scale"))?;
    let failed = sweep.runs.iter().filter(|r| r.error.is_some()).count();
    if failed > 0 {
        bail!("{failed} of {} runs failed; scale.md shows the others → {}", sweep.runs.len(), a.out.display());
    }
    out!(
        "scale: {} sizes × {} walks × {} modes × {} taus → {}",
        a.sizes.len(),
        a.walks,
        a.modes.len(),
        a.taus.len(),
        a.out.join("scale.md").display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_read_with_suffixes_and_print_back() {
        for (s, n) in
            [("2M", 2_000_000), ("100m", 100_000_000), ("1B", 1_000_000_000), ("500K", 500_000), ("1234", 1234), ("1.5M", 1_500_000)]
        {
            assert_eq!(parse_size(s), Ok(n), "{s}");
        }
        for s in ["", "M", "2X", "-1M", "0", "1e20"] {
            assert!(parse_size(s).is_err(), "{s}");
        }
        assert_eq!([2_000_000, 1_000_000_000, 500_000, 1234].map(label), ["2M", "1B", "500K", "1234"]);
    }
}
