//! `osw report`: error against run time. Runs every mode at every tau on one scene and path
//! (each run a child `osw render`, the switch a child `osw run`), compares each with exact
//! visibility (`osw exact`: at full detail for PVS/exact, and at the run's tau for culling error
//! apart from LOD error) and with the full-detail frustum-only images (`vfc` at tau 0), and
//! writes report.md (tables in the form of occlusion switch tables 1-3 and CHC table 1),
//! report.json and error_vs_time.png/.svg.
//!
//! Every run keeps its own directory under DIR/runs; a run whose results are there for the
//! same scene, path and size is not repeated, so an interrupted report resumes where it stopped.

use crate::plot::{Chart, Series};
use crate::walk_args::WalkArgs;
use anyhow::{Context, bail};
use osw_render::Mode;
use osw_render::results::{self, Compare, Entry, ExactFrame, Input, Report, Summary, Traffic};
use osw_render::stats::mean;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    walk: WalkArgs,
    /// Pixels-of-error thresholds to run each mode at.
    #[arg(long, value_delimiter = ',', default_value = "0,1,2,5,10,20")]
    taus: Vec<f64>,
    /// Modes to run: vfc, sw, chc, hzb, prev, ovc (single process) and switch (`osw run`).
    #[arg(long, value_delimiter = ',', default_value = "vfc,sw,chc,hzb,prev,switch,ovc")]
    modes: Vec<Mode>,
    /// Adaptive-culling thresholds (Bartz 1999 eq. 1) to run ovc, prev and the switch at, each a
    /// point of its own (0: conservative).
    #[arg(long, value_delimiter = ',', default_value = "0")]
    adaptive: Vec<f64>,
    /// Keep every run's frame PNGs (by default they are deleted once compared).
    #[arg(long)]
    keep_frames: bool,
    /// Output directory: report.md, report.json, error_vs_time.png/.svg, runs/, exact/ (full
    /// detail) and exact-tauT/ (at each tau T > 0).
    #[arg(long)]
    out: PathBuf,
}

fn run_name(mode: Mode, tau: f64, adaptive: f64) -> String {
    if adaptive == 0.0 { format!("{mode}-tau{tau}") } else { format!("{mode}-tau{tau}-adaptive{adaptive}") }
}

/// Runs `osw ARGS` with its output in `log`; on failure the error quotes the log's last line.
pub(crate) fn osw(args: &[String], log: &Path) -> anyhow::Result<()> {
    let exe = std::env::current_exe()?;
    let status = Command::new(&exe)
        .args(args)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(log)?)
        .stderr(std::fs::File::create(log.with_extension("err"))?)
        .status()
        .with_context(|| format!("starting {}", exe.display()))?;
    if !status.success() {
        let err = std::fs::read_to_string(log.with_extension("err")).unwrap_or_default();
        let last = err.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("");
        bail!("osw {} failed ({status}): {last}", args[0]);
    }
    Ok(())
}

struct Plan<'a> {
    a: &'a Args,
    scene_hash: String,
    exact: PathBuf,
    reference: PathBuf,
}

impl Plan<'_> {
    /// The walk's arguments of a child `osw`; `adapter` for those that take `--adapter` (`osw
    /// run` does not: the nodes choose as `osw render` does by default).
    fn walk_args(&self, adapter: bool) -> Vec<String> {
        let w = &self.a.walk;
        let mut v = vec![
            "--scene".into(),
            w.scene.display().to_string(),
            "--path".into(),
            w.path.display().to_string(),
            "--size".into(),
            format!("{}x{}", w.size.0, w.size.1),
        ];
        if let Some(ad) = w.adapter.as_ref().filter(|_| adapter) {
            v.extend(["--adapter".into(), ad.clone()]);
        }
        v
    }

    /// What a run or exact visibility was made from.
    fn input(&self) -> Input {
        let w = &self.a.walk;
        Input { scene_hash: self.scene_hash.clone(), path: w.path.display().to_string(), width: w.size.0, height: w.size.1 }
    }

    /// The run in `dir` is there, compared, from an earlier report on the same input.
    fn done(&self, dir: &Path) -> bool {
        Summary::read(dir).is_ok_and(|s| Input::of(&s) == self.input()) && dir.join("compare/compare.json").exists()
    }

    /// Where exact visibility at `tau` goes: exact/ at full detail, exact-tauT/ otherwise.
    fn exact_dir(&self, tau: f64) -> PathBuf {
        if tau == 0.0 { self.exact.clone() } else { self.a.out.join(format!("exact-tau{tau}")) }
    }

    /// Exact visibility at `tau`, unless it is there for the same input.
    fn exact(&self, tau: f64) -> anyhow::Result<()> {
        let dir = self.exact_dir(tau);
        let stamp = dir.join("input.json");
        if results::read_json::<Input>(&stamp).is_ok_and(|i| i == self.input()) {
            return Ok(());
        }
        std::fs::create_dir_all(&dir)?;
        let _ = std::fs::remove_file(&stamp);
        let out = vec!["--tau".to_string(), tau.to_string(), "--out".to_string(), dir.display().to_string()];
        osw(&[vec!["exact".to_string()], self.walk_args(true), out].concat(), &dir.with_extension("log"))?;
        results::write_json(&stamp, &self.input())?;
        Ok(())
    }

    /// One mode at one tau (and adaptive threshold) into `dir`: the run, then its comparison
    /// with the reference.
    fn run(&self, mode: Mode, tau: f64, adaptive: f64, dir: &Path) -> anyhow::Result<()> {
        let frames_kept = dir != self.reference || osw_render::output::frame_path(dir, 0).exists();
        if self.done(dir) && frames_kept {
            return Ok(());
        }
        std::fs::create_dir_all(dir)?;
        let mut args: Vec<String> = match mode {
            Mode::Switch => [vec!["run".to_string()], self.walk_args(false)].concat(),
            _ => [vec!["render".to_string(), "--mode".into(), mode.name().into()], self.walk_args(true)].concat(),
        };
        args.extend(["--tau".into(), tau.to_string(), "--out".into(), dir.display().to_string()]);
        if adaptive > 0.0 {
            args.extend(["--adaptive".into(), adaptive.to_string()]);
        }
        // CHC as CHC runs it: every frame culled (cost-adaptive culling is osw's).
        if mode == Mode::Chc {
            args.push("--always-cull".into());
        }
        osw(&args, &dir.join("run.log"))?;
        let compare = [
            "compare",
            "--a",
            &dir.display().to_string(),
            "--b",
            &self.reference.display().to_string(),
            "--exact",
            &self.exact.display().to_string(),
            "--exact-lod",
            &self.exact_dir(tau).display().to_string(),
            "--popping",
            "--out",
            &dir.join("compare").display().to_string(),
        ]
        .map(String::from);
        osw(&compare, &dir.join("compare.log"))?;
        if !self.a.keep_frames && dir != self.reference {
            let _ = std::fs::remove_dir_all(dir.join("frames"));
        }
        Ok(())
    }
}

fn entry(mode: Mode, tau: f64, adaptive: f64, dir: &Path) -> anyhow::Result<Entry> {
    let s = Summary::read(dir)?;
    let file = dir.join("compare/compare.json");
    let c: Compare = results::read_json(&file)?;
    let missing = |what: &str| anyhow::anyhow!("{}: no {what}", file.display());
    let culling = c.culling_a.as_ref().ok_or_else(|| missing("culling_a"))?;
    Ok(Entry {
        mode,
        tau,
        adaptive,
        frame_ms_median: s.frame_ms_median,
        frame_ms_p95: s.frame_ms_p95,
        or_ms_median: s.or_ms_median().with_context(|| format!("{}: no OR time (no node statistics with OR frames)", dir.display()))?,
        hc_ms_median: s.hc_ms_median,
        rvg_ms_median: s.rvg_ms_median,
        speedup_vs_vfc: None,
        triangles_drawn_mean: s.triangles_drawn_mean,
        pvs_nodes_mean: s.pvs_nodes_mean,
        tests_mean: s.tests_mean,
        clusters_mean: s.clusters_mean,
        clusters_frustum_culled_fraction: s.clusters_frustum_culled_fraction,
        clusters_cone_culled_fraction: s.clusters_cone_culled_fraction,
        clusters_occlusion_culled_fraction: s.clusters_occlusion_culled_fraction,
        triangles_backface_culled_mean: s.triangles_backface_culled_mean,
        triangles_small_culled_mean: s.triangles_small_culled_mean,
        pvs_exact_leaves: culling.pvs_exact_leaves_ratio_mean,
        pvs_exact_triangles: culling.pvs_exact_triangles_ratio_mean,
        drawn_exact_triangles: culling.drawn_exact_triangles_ratio_mean.ok_or_else(|| missing("drawn_exact_triangles_ratio_mean"))?,
        false_culled_leaves_total: culling.false_culled_leaves_total,
        frames_with_false_culling: culling.frames_with_false_culling,
        false_culled_at_tau_total: culling.lod_false_culled_total.ok_or_else(|| missing("lod_false_culled_total"))?,
        psnr_db_median: c.psnr_db_median,
        psnr_db_min: c.psnr_db_min,
        identical_frames: c.identical_frames as u64,
        differing_fraction_mean: c.differing_fraction_mean,
        differing_fraction_max: c.differing_fraction_max,
        popping_fraction_mean: c.popping_a.as_ref().ok_or_else(|| missing("popping_a"))?.fraction_mean,
        traffic: s.switch().map(Traffic::from),
        error: None,
    })
}

/// Frames and means of the `exact.csv` columns visible_leaves and visible_triangles.
fn exact_means(dir: &Path) -> anyhow::Result<(usize, f64, f64)> {
    let rows: Vec<ExactFrame> = results::csv::read(&dir.join("exact.csv"))?;
    Ok((rows.len(), mean(rows.iter().map(|r| r.visible_leaves as f64)), mean(rows.iter().map(|r| r.visible_triangles as f64))))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if let Some(t) = a.taus.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
        bail!("--taus: {t} is not a pixel error (a finite number ≥ 0)");
    }
    if let Some(t) = a.adaptive.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
        bail!("--adaptive: {t} is not a threshold (a finite number ≥ 0)");
    }
    let scene = osw_scene::SceneFile::open(&a.walk.scene)?;
    let scene_triangles = scene.header().leaf_triangles;
    let scene_hash = osw_scene::format::hash_hex(scene.content_hash());
    drop(scene);
    std::fs::create_dir_all(a.out.join("runs"))?;
    let plan = Plan { a: &a, scene_hash, exact: a.out.join("exact"), reference: a.out.join("runs").join(run_name(Mode::Vfc, 0.0, 0.0)) };

    // Every mode at every tau; those with adaptive culling also at every threshold.
    let conservative = [0.0];
    let runs: Vec<(Mode, f64, f64)> = a
        .modes
        .iter()
        .flat_map(|&m| {
            let adaptive: &[f64] = if m.adaptive() { &a.adaptive } else { &conservative };
            a.taus.iter().flat_map(move |&t| adaptive.iter().map(move |&ad| (m, t, ad)))
        })
        .collect();
    let bar = crate::progress::steps(runs.len() as u64 + 1 + a.taus.len().max(1) as u64, "report");
    let dir = |mode: Mode, tau: f64, adaptive: f64| a.out.join("runs").join(run_name(mode, tau, adaptive));
    // Full detail for PVS/exact, and the scene as drawn at each tau for culling error.
    for tau in std::iter::once(0.0).chain(a.taus.iter().copied().filter(|&t| t > 0.0)) {
        bar.set_message(format!("exact tau {tau}"));
        plan.exact(tau)?;
        bar.inc(1);
    }
    // The reference first, while any run needs it: every run's image error is measured
    // against its frames.
    bar.set_message("vfc tau 0 (reference)");
    if runs.iter().any(|&(m, t, ad)| !plan.done(&dir(m, t, ad))) {
        plan.run(Mode::Vfc, 0.0, 0.0, &plan.reference).context("the reference run (vfc at tau 0)")?;
    }
    bar.inc(1);
    let mut entries = Vec::new();
    for &(mode, tau, adaptive) in &runs {
        bar.set_message(format!("{} tau {tau}", run_name(mode, tau, adaptive)));
        let dir = dir(mode, tau, adaptive);
        let e = plan.run(mode, tau, adaptive, &dir).and_then(|()| entry(mode, tau, adaptive, &dir)).unwrap_or_else(|e| {
            bar.println(format!("osw: {} failed: {e:#}", run_name(mode, tau, adaptive)));
            Entry { mode, tau, adaptive, error: Some(format!("{e:#}")), ..Default::default() }
        });
        entries.push(e);
        bar.inc(1);
    }
    bar.finish_and_clear();
    if !a.keep_frames {
        let _ = std::fs::remove_dir_all(plan.reference.join("frames"));
    }
    let vfc_ms: Vec<(f64, f64)> =
        entries.iter().filter(|e| e.mode == Mode::Vfc && e.error.is_none()).map(|e| (e.tau, e.frame_ms_median)).collect();
    for e in entries.iter_mut().filter(|e| e.error.is_none() && e.frame_ms_median > 0.0) {
        e.speedup_vs_vfc = vfc_ms.iter().find(|v| v.0 == e.tau).map(|v| v.1 / e.frame_ms_median);
    }
    let (frames, exact_leaves_mean, exact_triangles_mean) = exact_means(&plan.exact)?;
    let report = Report {
        scene: a.walk.scene.display().to_string(),
        path: a.walk.path.display().to_string(),
        width: a.walk.size.0,
        height: a.walk.size.1,
        frames,
        scene_triangles,
        exact_leaves_mean,
        exact_triangles_mean,
        runs: entries,
    };
    results::write_json(&a.out.join("report.json"), &report)?;
    std::fs::write(a.out.join("report.md"), markdown(&report, &a))?;
    let failed: Vec<String> = report.runs.iter().filter(|e| e.error.is_some()).map(|e| run_name(e.mode, e.tau, e.adaptive)).collect();
    if failed.len() < report.runs.len() {
        crate::plot::write_log_x(&error_chart(&report), &a.out.join("error_vs_time"))?;
    }
    if !failed.is_empty() {
        bail!(
            "{} of {} runs failed ({}); the report shows the others → {}",
            failed.len(),
            report.runs.len(),
            failed.join(", "),
            a.out.display()
        );
    }
    for e in report.runs.iter().filter(|e| e.mode != Mode::Vfc && e.error.is_none()) {
        out!("{}", at_a_glance(e, frames));
    }
    out!(
        "report: {} runs ({} modes × {} taus) over {frames} frames → {}",
        report.runs.len(),
        a.modes.len(),
        a.taus.len(),
        a.out.join("report.md").display()
    );
    Ok(())
}

/// One run in a line: speed against vfc at its tau, image error against full-detail vfc, and
/// its error split into culling error (nodes visible at its tau that it does not draw) and LOD
/// error (leaves visible at full detail that coarse LODs hide).
fn at_a_glance(e: &Entry, frames: usize) -> String {
    let speed = e.speedup_vs_vfc.map_or("–".into(), |s| format!("{s:.2}x"));
    let (culling, lod) = match e.false_culled_at_tau_total {
        0 => ("no culling error".to_string(), "all of it LOD error"),
        n => (format!("culling error: {n} nodes visible at tau {} not drawn", e.tau), "LOD and culling error"),
    };
    let psnr = e.psnr_db_median.map_or("∞".to_string(), |db| format!("{db:.1} dB"));
    format!(
        "{} at tau {}: {speed} vfc's speed ({:.1} ms a frame), {}/{frames} frames as full-detail vfc (PSNR median {psnr}), {culling}; {} leaves visible at full detail not drawn ({lod})",
        e.label(),
        e.tau,
        e.frame_ms_median,
        e.identical_frames,
        e.false_culled_leaves_total
    )
}

/// One series per mode (and adaptive threshold), one point per tau, and the Pareto front over
/// all of them: the runs that no other run beats in both frame time and image error.
fn error_chart<'a>(r: &Report) -> Chart<'a> {
    let done: Vec<&Entry> = r.runs.iter().filter(|e| e.error.is_none()).collect();
    let point = |e: &Entry| (e.frame_ms_median, e.differing_fraction_mean * 100.0);
    let mut labels: Vec<String> = Vec::new();
    for e in &done {
        if !labels.contains(&e.label()) {
            labels.push(e.label());
        }
    }
    let mut series: Vec<Series> = labels
        .iter()
        .map(|l| {
            let runs: Vec<&&Entry> = done.iter().filter(|e| &e.label() == l).collect();
            Series {
                name: l.clone(),
                points: runs.iter().map(|e| point(e)).collect(),
                point_labels: runs.iter().map(|e| format!("τ{}", e.tau)).collect(),
                bold: false,
            }
        })
        .collect();
    let front = pareto(&done.iter().map(|e| point(e)).collect::<Vec<_>>());
    series.push(Series {
        name: "Pareto front".into(),
        points: front.iter().map(|&k| point(done[k])).collect(),
        point_labels: front.iter().map(|_| String::new()).collect(),
        bold: true,
    });
    Chart {
        title: "Image error against frame time (one point per tau)",
        x: "frame time, median (ms, logarithmic)",
        y: "pixels differing from full-detail vfc, mean (%)",
        series,
    }
}

/// Indices of the points (time, error) that no other point beats in both (ties kept once),
/// by increasing time.
fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0).then(points[a].1.total_cmp(&points[b].1)));
    let mut best = f64::INFINITY;
    order
        .into_iter()
        .filter(|&k| {
            let better = points[k].1 < best;
            best = best.min(points[k].1);
            better
        })
        .collect()
}

/// One row per run that finished, in order.
fn finished_rows(r: &Report, row: impl Fn(&Entry) -> Vec<String>) -> Vec<Vec<String>> {
    r.runs.iter().filter(|e| e.error.is_none()).map(row).collect()
}

/// A Markdown table: rows of cells under a header.
fn table(out: &mut String, header: &[String], rows: &[Vec<String>]) {
    let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
    out.push_str(&line(header));
    out.push_str(&line(&vec!["---".to_string(); header.len()]));
    rows.iter().for_each(|r| out.push_str(&line(r)));
    out.push('\n');
}

fn markdown(r: &Report, a: &Args) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# osw report\n\nScene `{}`, path `{}` ({} frames), {}x{}. Image error is against `vfc` at tau 0 \
         (full detail, frustum culling only); culling error against exact visibility (item buffer at full \
         detail, `osw exact`): on average {:.0} leaves and {:.0} triangles are visible.\n",
        r.scene, r.path, r.frames, r.width, r.height, r.exact_leaves_mean, r.exact_triangles_mean
    );
    paper_tables(&mut md, r, a);
    method_table(&mut md, r);
    cluster_table(&mut md, r);
    error_table(&mut md, r);
    culling_table(&mut md, r);
    traffic_table(&mut md, r);
    md
}

/// The occlusion switch's tables 1-3: a row per tau, a column per mode.
fn paper_tables(md: &mut String, r: &Report, a: &Args) {
    let get = |m: Mode, t: f64| r.runs.iter().find(|e| e.mode == m && e.tau == t && e.adaptive == 0.0);
    let cell = |m: Mode, t: f64, f: &dyn Fn(&Entry) -> String| match get(m, t) {
        Some(e) if e.error.is_none() => f(e),
        Some(_) => "failed".into(),
        None => "–".into(),
    };
    let by_tau = |first: &str, f: &dyn Fn(&Entry) -> String, extra: Option<&dyn Fn(f64) -> String>| {
        let mut header = vec!["tau (px)".to_string()];
        header.extend(a.modes.iter().map(|m| format!("{m} {first}")));
        if extra.is_some() {
            header.push("exact".into());
        }
        let rows: Vec<Vec<String>> = a
            .taus
            .iter()
            .map(|&t| {
                let mut row = vec![t.to_string()];
                row.extend(a.modes.iter().map(|&m| cell(m, t, f)));
                if let Some(x) = extra {
                    row.push(x(t));
                }
                row
            })
            .collect();
        (header, rows)
    };
    md.push_str("## Frame rate (occlusion switch, table 1)\n\nFrames per second from the median frame time.\n\n");
    let (h, rows) = by_tau("fps", &|e| format!("{:.1}", 1000.0 / e.frame_ms_median.max(1e-9)), None);
    table(md, &h, &rows);
    md.push_str("## Triangles drawn against exactly visible triangles (occlusion switch, table 2)\n\nMeans per frame.\n\n");
    let (h, rows) = by_tau("triangles", &|e| format!("{:.0}", e.triangles_drawn_mean), Some(&|_| format!("{:.0}", r.exact_triangles_mean)));
    table(md, &h, &rows);
    md.push_str(
        "## Objects drawn against exactly visible objects (occlusion switch, table 3)\n\nLeaves drawn per exactly visible leaf \
         at full detail (PVS/exact; an HLOD counts for the visible leaves it stands for), then the culling error over \
         the whole path: nodes visible in the scene as drawn at that tau (`osw exact --tau`) that the method does not \
         draw (0 for a conservative method at every tau), and after the slash leaves visible at full detail that it \
         does not draw. The two differ at tau > 0 only: coarse LODs drawn as occluders hide leaves that are visible \
         at full detail, which is LOD error, not culling error.\n\n",
    );
    let (h, rows) = by_tau(
        "PVS/exact (false-culled at tau / at full detail)",
        &|e| format!("{:.2} ({} / {})", e.pvs_exact_leaves, e.false_culled_at_tau_total, e.false_culled_leaves_total),
        Some(&|_| format!("{:.0} leaves", r.exact_leaves_mean)),
    );
    table(md, &h, &rows);
}

/// CHC's table 1: a row per run.
fn method_table(md: &mut String, r: &Report) {
    md.push_str(
        "## Per-method statistics (CHC, table 1)\n\nMeans per frame; times are medians in ms; HC tests/s is tests \
         over the HC time; speedup is vfc's median frame time at the same tau over this method's.\n\n",
    );
    let header: Vec<String> =
        ["method", "tau", "tests", "OR ms", "HC ms", "HC tests/s", "RVG ms", "triangles", "frame ms", "p95 ms", "speedup"]
            .map(String::from)
            .to_vec();
    let rows: Vec<Vec<String>> = r
        .runs
        .iter()
        .map(|e| match &e.error {
            Some(err) => {
                let mut row = vec![e.label(), e.tau.to_string(), format!("failed: {}", err.replace('|', "/"))];
                row.resize(header.len(), "–".into());
                row
            }
            None => vec![
                e.label(),
                e.tau.to_string(),
                format!("{:.0}", e.tests_mean),
                format!("{:.1}", e.or_ms_median),
                format!("{:.1}", e.hc_ms_median),
                if e.tests_mean > 0.0 { format!("{:.0}k", e.tests_mean / e.hc_ms_median.max(1e-9)) } else { "–".into() },
                format!("{:.1}", e.rvg_ms_median),
                format!("{:.0}", e.triangles_drawn_mean),
                format!("{:.1}", e.frame_ms_median),
                format!("{:.1}", e.frame_ms_p95),
                e.speedup_vs_vfc.map_or("–".into(), |s| format!("{s:.2}")),
            ],
        })
        .collect();
    table(md, &header, &rows);
}

/// Culling inside the visible nodes: a row per finished run.
fn cluster_table(md: &mut String, r: &Report) {
    md.push_str(
        "## Clusters inside the visible nodes\n\nRVG's clusters a frame, the shares it skips \
         as outside the frustum, facing away and hidden; of the triangles of the clusters it draws, those it skips \
         as facing away and as covering no pixel centre, a frame; the triangles it draws, and the ratio to the exactly \
         visible triangles of the PVS's nodes' triangles and of the triangles drawn.\n\n",
    );
    let header: Vec<String> = [
        "method",
        "tau",
        "clusters",
        "frustum %",
        "facing away %",
        "hidden %",
        "back faces",
        "no pixel",
        "triangles",
        "PVS/exact triangles",
        "drawn/exact triangles",
    ]
    .map(String::from)
    .to_vec();
    let pct = |x: f64| format!("{:.1}", x * 100.0);
    let rows = finished_rows(r, |e| {
        vec![
            e.label(),
            e.tau.to_string(),
            format!("{:.0}", e.clusters_mean),
            pct(e.clusters_frustum_culled_fraction),
            pct(e.clusters_cone_culled_fraction),
            pct(e.clusters_occlusion_culled_fraction),
            format!("{:.0}", e.triangles_backface_culled_mean),
            format!("{:.0}", e.triangles_small_culled_mean),
            format!("{:.0}", e.triangles_drawn_mean),
            format!("{:.1}", e.pvs_exact_triangles),
            format!("{:.1}", e.drawn_exact_triangles),
        ]
    });
    table(md, &header, &rows);
}

/// Image and temporal error against frame time: a row per finished run, and the plot.
fn error_table(md: &mut String, r: &Report) {
    md.push_str(
        "## Error against run time\n\nPSNR against full-detail vfc (∞ when every frame is identical), pixels that differ, \
         popping (temporal error: pixels that change by more than 2/255 when a frame's nodes are drawn with the previous \
         frame's detail, osw_render::popping) and the frame time that buys it. The plot is `error_vs_time.png`.\n\n",
    );
    let header: Vec<String> = [
        "method",
        "tau",
        "frame ms",
        "PSNR median dB",
        "PSNR min dB",
        "identical frames",
        "differing px mean %",
        "differing px max %",
        "popping px mean %",
        "PVS/exact triangles",
    ]
    .map(String::from)
    .to_vec();
    let db = |v: Option<f64>| v.map_or("∞".to_string(), |x| format!("{x:.1}"));
    let rows = finished_rows(r, |e| {
        vec![
            e.label(),
            e.tau.to_string(),
            format!("{:.1}", e.frame_ms_median),
            db(e.psnr_db_median),
            db(e.psnr_db_min),
            format!("{}/{}", e.identical_frames, r.frames),
            format!("{:.3}", e.differing_fraction_mean * 100.0),
            format!("{:.3}", e.differing_fraction_max * 100.0),
            format!("{:.3}", e.popping_fraction_mean * 100.0),
            format!("{:.2}", e.pvs_exact_triangles),
        ]
    });
    table(md, &header, &rows);
    md.push_str("![image error against frame time](error_vs_time.png)\n");
}

/// Bartz 1999's table 2: a row per finished run.
fn culling_table(md: &mut String, r: &Report) {
    md.push_str(
        "\n## Culling and speed-up (Bartz 1999, table 2)\n\nThe share of the scene's full-detail triangles not drawn \
         (culled by frustum, occlusion and LOD), the culling error at the run's tau (nodes visible at that tau not drawn; \
         0 for a conservative run), and the speed-up over vfc at the same tau.\n\n",
    );
    let header: Vec<String> = ["method", "tau", "culled %", "false-culled at tau", "speed-up over vfc"].map(String::from).to_vec();
    let rows = finished_rows(r, |e| {
        vec![
            e.label(),
            e.tau.to_string(),
            format!("{:.1}", (1.0 - e.triangles_drawn_mean / r.scene_triangles.max(1) as f64) * 100.0),
            e.false_culled_at_tau_total.to_string(),
            e.speedup_vs_vfc.map_or("–".into(), |s| format!("{s:.2}")),
        ]
    });
    table(md, &header, &rows);
}

/// The switch's traffic, where a run is the switch's.
fn traffic_table(md: &mut String, r: &Report) {
    let switch: Vec<(&Entry, &Traffic)> = r.runs.iter().filter_map(|e| Some((e, e.traffic.as_ref()?))).collect();
    if !switch.is_empty() {
        md.push_str(
            "\n## The switch's traffic (occlusion switch sec. 3.5, fig. 3)\n\nMeans per frame over HC -> RVG: ids sent as deltas \
             against the visible set's size (what sending it whole would cost), all bytes (camera, deltas, end of frame), \
             and the bytes of the id-carrying messages per id; then latency from camera sample to displayed frame. \
             `osw bandwidth` gives every link.\n\n",
        );
        let header: Vec<String> =
            ["tau", "ids sent", "visible set", "ids saved %", "bytes", "bytes per id", "latency median ms", "latency p95 ms"]
                .map(String::from)
                .to_vec();
        let rows: Vec<Vec<String>> = switch
            .iter()
            .map(|(e, t)| {
                vec![
                    e.tau.to_string(),
                    format!("{:.1}", t.ids_sent_mean),
                    format!("{:.1}", t.ids_full_mean),
                    format!("{:.1}", t.incremental_saved_fraction * 100.0),
                    format!("{:.0}", t.bytes_per_frame_mean),
                    format!("{:.2}", t.id_bytes_per_id),
                    format!("{:.1}", t.latency_ms_median),
                    format!("{:.1}", t.latency_ms_p95),
                ]
            })
            .collect();
        table(md, &header, &rows);
    }
}

#[cfg(test)]
mod tests {
    use super::pareto;

    #[test]
    fn the_pareto_front_keeps_what_nothing_beats_in_both() {
        // (time, error): 1 beats 3 (faster, less error); 0, 1, 2 and 4 trade one for the other.
        let p = [(10.0, 0.0), (5.0, 1.0), (2.0, 5.0), (6.0, 2.0), (1.0, 9.0), (5.0, 1.0)];
        assert_eq!(pareto(&p), vec![4, 2, 1, 0]);
        assert!(pareto(&[]).is_empty());
    }
}
