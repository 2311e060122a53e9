//! `osw latency`: one-way latency of each link of a switch run and the latency from camera
//! sample to displayed frame, with median, p95 and max, and a plot over the frames. The
//! one-way figures come from wall-clock stamps corrected by the clock offsets the display
//! estimated at start-up (NTP-style, `osw_wire::clock`), so they hold across machines too.
//! Given several runs (e.g. one per link delay), a table over them and one curve per run.
//! Each run's stages (`osw_render::results::STAGES`) are stacked per frame in
//! stages.png (stages-K.png of the K-th run when there are several), under the latency, and
//! the floor (the sum of the busy stages' medians) is set beside it, in ms and in frames.

use crate::plot::{Chart, Series};
use osw_render::results::{self, DisplayFrame, Summary};
use osw_render::results::{STAGES, latency_floor_ms};
use osw_render::stats::quantile;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Switch run directories (`osw run`, or scripts/netns-cluster.sh): one or more.
    #[arg(long, required = true, num_args = 1..)]
    run: Vec<PathBuf>,
    /// Output directory: latency.json, latency.md, latency.png/.svg, stages.png/.svg.
    #[arg(long)]
    out: PathBuf,
}

/// A column of the display's frames: its name, what it measures, and whether the last frame
/// has it (the last end of frame reaches no OR).
struct Link {
    column: &'static str,
    what: &'static str,
    of: fn(&DisplayFrame) -> f64,
    last_frame: bool,
}

const LINKS: [Link; 4] = [
    Link { column: "latency_ms", what: "camera sample to displayed frame", of: |f| f.latency_ms, last_frame: true },
    Link { column: "camera_link_ms", what: "RVG → HC (camera)", of: |f| f.camera_link_ms, last_frame: true },
    Link { column: "eof_link_ms", what: "HC → RVG (end of frame)", of: |f| f.eof_link_ms, last_frame: true },
    Link { column: "peer_link_ms", what: "HC → OR (end of frame)", of: |f| f.peer_link_ms, last_frame: false },
];

#[derive(Serialize)]
struct Stat {
    column: &'static str,
    what: &'static str,
    median_ms: f64,
    p95_ms: f64,
    max_ms: f64,
}

#[derive(Serialize)]
struct Run {
    run: String,
    /// The links' shaping (links.txt of a namespace run), else "loopback".
    links: String,
    frames: usize,
    clock_offset_a_us: f64,
    clock_offset_b_us: f64,
    clock_rtt_a_us: f64,
    clock_rtt_b_us: f64,
    latency: Vec<Stat>,
    frame_ms_median: f64,
    latency_frames_median: f64,
    latency_frames_p95: f64,
    /// None for a run whose nodes stamped no stages (protocol 12 and before).
    floor_ms: Option<f64>,
    floor_frames: Option<f64>,
    stages: Vec<Stat>,
    #[serde(skip)]
    per_frame: Vec<Vec<f64>>,
    #[serde(skip)]
    stage_per_frame: Vec<Vec<f64>>,
}

fn read(dir: &Path) -> anyhow::Result<Run> {
    let summary = Summary::read(dir)?;
    let Some(sw) = summary.switch() else { anyhow::bail!("{} is not a switch run (osw run): its mode is {}", dir.display(), summary.mode) };
    let rows: Vec<DisplayFrame> = results::csv::read(&dir.join("stats.csv"))?;
    let frames = rows.len();
    let (mut latency, mut per_frame) = (Vec::new(), Vec::new());
    for link in &LINKS {
        let n = if link.last_frame { frames } else { frames.saturating_sub(1) };
        let v: Vec<f64> = rows[..n].iter().map(link.of).collect();
        let (column, what) = (link.column, link.what);
        latency.push(Stat { column, what, median_ms: quantile(&v, 0.5), p95_ms: quantile(&v, 0.95), max_ms: quantile(&v, 1.0) });
        per_frame.push(v);
    }
    let (mut stages, mut stage_per_frame) = (Vec::new(), Vec::new());
    let staged = rows.iter().any(|r| r.hc_stage_ms > 0.0);
    for s in STAGES.iter().filter(|_| staged) {
        let v: Vec<f64> = rows.iter().map(s.of).collect();
        stages.push(Stat {
            column: s.column,
            what: s.what,
            median_ms: quantile(&v, 0.5),
            p95_ms: quantile(&v, 0.95),
            max_ms: quantile(&v, 1.0),
        });
        stage_per_frame.push(v);
    }
    let frame_ms_median = summary.frame_ms_median.max(f64::MIN_POSITIVE);
    let floor_ms = staged.then(|| latency_floor_ms(&rows));
    let links = std::fs::read_to_string(dir.join("links.txt"))
        .ok()
        .and_then(|l| Some(l.lines().next()?.split_once(": ")?.1.to_owned()))
        .unwrap_or_else(|| "loopback".into());
    Ok(Run {
        run: dir.display().to_string(),
        links,
        frames,
        clock_offset_a_us: sw.clock_offset_a_us,
        clock_offset_b_us: sw.clock_offset_b_us,
        clock_rtt_a_us: sw.clock_rtt_a_us,
        clock_rtt_b_us: sw.clock_rtt_b_us,
        frame_ms_median,
        latency_frames_median: latency[0].median_ms / frame_ms_median,
        latency_frames_p95: latency[0].p95_ms / frame_ms_median,
        floor_ms,
        floor_frames: floor_ms.map(|f| f / frame_ms_median),
        latency,
        stages,
        per_frame,
        stage_per_frame,
    })
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let runs = a.run.iter().map(|d| read(d)).collect::<anyhow::Result<Vec<Run>>>()?;
    std::fs::create_dir_all(&a.out)?;
    std::fs::write(a.out.join("latency.json"), serde_json::to_string_pretty(&runs)?)?;
    let mut md = String::from(
        "| run | links | frame ms | latency median ms | p95 | max | median frames | p95 frames | floor ms | floor frames | RVG→HC ms | HC→RVG ms | HC→OR ms | clock offsets a, b µs |\n",
    );
    md.push_str("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for r in &runs {
        let s = &r.latency;
        let _ = writeln!(
            md,
            "| {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} | {} | {} | {:.3} | {:.3} | {:.3} | {:.0} ± {:.0}, {:.0} ± {:.0} |",
            r.run,
            r.links,
            r.frame_ms_median,
            s[0].median_ms,
            s[0].p95_ms,
            s[0].max_ms,
            r.latency_frames_median,
            r.latency_frames_p95,
            shown(r.floor_ms, 1),
            shown(r.floor_frames, 2),
            s[1].median_ms,
            s[2].median_ms,
            s[3].median_ms,
            r.clock_offset_a_us,
            r.clock_rtt_a_us / 2.0,
            r.clock_offset_b_us,
            r.clock_rtt_b_us / 2.0
        );
        out!(
            "latency: {} ({}): {:.1} ms median ({:.2} frames of {:.1} ms, p95 {:.2}), floor {} ms ({} frames), links {:.3} / {:.3} / {:.3} ms",
            r.run,
            r.links,
            s[0].median_ms,
            r.latency_frames_median,
            r.frame_ms_median,
            r.latency_frames_p95,
            shown(r.floor_ms, 1),
            shown(r.floor_frames, 2),
            s[1].median_ms,
            s[2].median_ms,
            s[3].median_ms
        );
    }
    md.push_str("\n| run | stage | median ms | p95 | max |\n| --- | --- | --- | --- | --- |\n");
    for r in &runs {
        for s in &r.stages {
            let _ = writeln!(md, "| {} | {} | {:.2} | {:.2} | {:.2} |", r.run, s.what, s.median_ms, s.p95_ms, s.max_ms);
        }
    }
    std::fs::write(a.out.join("latency.md"), &md)?;
    for (k, r) in runs.iter().enumerate() {
        if r.stages.is_empty() {
            out!("latency: {}: no stage stamps (its nodes speak protocol 12 or older): no stages plot", r.run);
            continue;
        }
        let name = if runs.len() == 1 { "stages".to_string() } else { format!("stages-{}", k + 1) };
        crate::plot::write(&stacked(r), &a.out.join(name))?;
    }
    let points = |v: &[f64]| v.iter().enumerate().map(|(i, &y)| (i as f64, y)).collect();
    let series: Vec<Series> = match runs.as_slice() {
        // One run: each link; several: camera-to-display latency of each run.
        [r] => LINKS
            .iter()
            .zip(&r.per_frame)
            .map(|(link, v)| Series { name: link.what.into(), points: points(v), point_labels: vec![], bold: false })
            .collect(),
        _ => runs
            .iter()
            .map(|r| Series {
                name: format!("{} ({})", r.run, r.links),
                points: points(&r.per_frame[0]),
                point_labels: vec![],
                bold: false,
            })
            .collect(),
    };
    crate::plot::write(&Chart { title: "Latency per frame", x: "frame", y: "ms", series }, &a.out.join("latency"))?;
    out!("latency: → {}", a.out.display());
    Ok(())
}

/// A run's stages stacked per frame: each curve is the time from the camera's sample to the
/// end of that stage; the latency itself in bold above them (the gap: what no stamp covers).
/// From the second frame: the first waits for start-up.
fn stacked(r: &Run) -> Chart<'static> {
    let frames = r.per_frame[0].len();
    let mut sum = vec![0.0; frames];
    let mut series = Vec::new();
    for (s, v) in STAGES.iter().zip(&r.stage_per_frame) {
        for (acc, x) in sum.iter_mut().zip(v) {
            *acc += x;
        }
        let points = sum.iter().enumerate().skip(1).map(|(i, &y)| (i as f64, y)).collect();
        series.push(Series { name: format!("+ {}", s.what), points, point_labels: vec![], bold: false });
    }
    let points = r.per_frame[0].iter().enumerate().skip(1).map(|(i, &y)| (i as f64, y)).collect();
    series.push(Series { name: "latency".into(), points, point_labels: vec![], bold: true });
    Chart { title: "Where each frame's latency goes (stages stacked)", x: "frame", y: "ms", series }
}

/// A figure of a table, or "-" where the run has none.
fn shown(v: Option<f64>, decimals: usize) -> String {
    v.map_or("-".into(), |v| format!("{v:.decimals$}"))
}
