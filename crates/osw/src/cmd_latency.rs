//! `osw latency`: one-way latency of each link of a switch run and the latency from camera
//! sample to displayed frame, with median, p95 and max, and a plot over the frames. The
//! one-way figures come from wall-clock stamps corrected by the clock offsets the display
//! estimated at start-up (NTP-style, `osw_wire::clock`), so they hold across machines too.

use crate::columns::Columns;
use crate::plot::{Chart, Series};
use anyhow::Context;
use osw_render::stats::quantile;
use serde::Serialize;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A switch run's directory (`osw run`, or the display's --out of a cluster run).
    #[arg(long)]
    run: PathBuf,
    /// Output directory: latency.json, latency.png/.svg.
    #[arg(long)]
    out: PathBuf,
}

/// The display's columns and what each measures.
const LINKS: [(&str, &str); 4] = [
    ("latency_ms", "camera sample to displayed frame"),
    ("camera_link_ms", "RVG → HC (camera)"),
    ("eof_link_ms", "HC → RVG (end of frame)"),
    ("peer_link_ms", "HC → OR (end of frame)"),
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
struct Report {
    frames: usize,
    clock_offset_a_us: f64,
    clock_offset_b_us: f64,
    clock_rtt_a_us: f64,
    clock_rtt_b_us: f64,
    latency: Vec<Stat>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(a.run.join("summary.json"))?)
        .with_context(|| format!("{}: summary.json", a.run.display()))?;
    let t = Columns::read(&a.run.join("stats.csv"))?;
    let frames = t.len();
    let mut stats = Vec::new();
    let mut series = Vec::new();
    for (column, what) in LINKS {
        let mut v = t.get(column)?;
        if column == "peer_link_ms" {
            // The last frame's end of frame reaches no OR.
            v.truncate(frames.saturating_sub(1));
        }
        stats.push(Stat { column, what, median_ms: quantile(&v, 0.5), p95_ms: quantile(&v, 0.95), max_ms: quantile(&v, 1.0) });
        series.push(Series {
            name: what.into(),
            points: v.iter().enumerate().map(|(i, &y)| (i as f64, y)).collect(),
            point_labels: vec![],
        });
    }
    let f = |k: &str| summary[k].as_f64().unwrap_or(0.0);
    let report = Report {
        frames,
        clock_offset_a_us: f("clock_offset_a_us"),
        clock_offset_b_us: f("clock_offset_b_us"),
        clock_rtt_a_us: f("clock_rtt_a_us"),
        clock_rtt_b_us: f("clock_rtt_b_us"),
        latency: stats,
    };
    std::fs::create_dir_all(&a.out)?;
    std::fs::write(a.out.join("latency.json"), serde_json::to_string_pretty(&report)?)?;
    crate::plot::write(&Chart { title: "Latency per frame", x: "frame", y: "ms", series }, &a.out.join("latency"))?;
    let s = &report.latency;
    out!(
        "latency: frame {:.1} ms median ({:.1} p95, {:.1} max); links RVG→HC {:.3}, HC→RVG {:.3}, HC→OR {:.3} ms median; clock offsets a {:.0} µs, b {:.0} µs (± {:.0}, {:.0}) → {}",
        s[0].median_ms,
        s[0].p95_ms,
        s[0].max_ms,
        s[1].median_ms,
        s[2].median_ms,
        s[3].median_ms,
        report.clock_offset_a_us,
        report.clock_offset_b_us,
        report.clock_rtt_a_us / 2.0,
        report.clock_rtt_b_us / 2.0,
        a.out.display()
    );
    Ok(())
}
