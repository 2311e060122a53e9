//! A sweep of `osw scale` and what it writes of it: its scenes and runs, each size, tau and mode
//! over its walks (the median of each figure and the worst walk), scale.md's tables and
//! scale.png's curves.

use crate::plot::{Chart, Series};
use osw_render::Mode;
use osw_render::stats::quantile;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The size as the sweep names it: 2M, 100M, 1B, 500K.
pub fn label(n: u64) -> String {
    match n {
        n if n >= 1_000_000_000 && n % 1_000_000_000 == 0 => format!("{}B", n / 1_000_000_000),
        n if n >= 1_000_000 && n % 1_000_000 == 0 => format!("{}M", n / 1_000_000),
        n if n >= 1_000 && n % 1_000 == 0 => format!("{}K", n / 1_000),
        n => n.to_string(),
    }
}

/// One scene of the sweep: what its build cost.
#[derive(Serialize, Clone)]
pub struct Scene {
    pub triangles: u64,
    pub label: String,
    pub build_seconds: f64,
    pub build_peak_rss_kb: u64,
    pub file_bytes: u64,
}

/// One run: a mode at a tau on one walk through one scene.
#[derive(Serialize, Clone, Default)]
pub struct Row {
    pub triangles: u64,
    /// The walk's seed.
    pub walk: u32,
    pub mode: Mode,
    pub tau: f64,
    pub frame_ms_median: f64,
    pub frame_ms_p95: f64,
    pub hc_tests_mean: f64,
    /// Of those, the retests after the traversal (the switch's from its nodes' statistics),
    /// the first pass's (the rest), and the traversal's tests of V(i-1)'s nodes, their
    /// siblings and what came into view (one GPU's runs: prev; none for the switch).
    pub hc_retests_mean: f64,
    pub hc_first_pass_tests_mean: f64,
    pub hc_tests_where: Option<[f64; 3]>,
    pub hc_ms_median: f64,
    pub or_ms_median: f64,
    pub rvg_ms_median: f64,
    pub triangles_drawn_mean: f64,
    pub pvs_nodes_mean: f64,
    /// CPU time a frame, all threads of every process of the run (on lavapipe the GPU's work
    /// is CPU work), the median frame's: the switch's three processes share this host's cores.
    pub cpu_ms_median: f64,
    /// Peak resident memory per process: `render`, or `display`, `node_a`, `node_b`.
    pub peak_rss_kb: BTreeMap<String, u64>,
    pub error: Option<String>,
}

#[derive(Serialize)]
pub struct Sweep {
    pub frames: u32,
    pub walks: u32,
    pub size: String,
    pub scenes: Vec<Scene>,
    pub runs: Vec<Row>,
    /// Each size, tau and mode over the walks (`crate::scale_report::over_walks`).
    pub over_walks: Vec<OverWalks>,
}

/// One size, tau and mode over the walks that ran without error. Ratios are taken walk by
/// walk against CHC's run of the same walk (none without CHC in the sweep).
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct OverWalks {
    pub triangles: u64,
    pub mode: Mode,
    pub tau: f64,
    pub walks: u32,
    pub frame_ms_median: f64,
    /// The slowest walk's median frame.
    pub frame_ms_worst: f64,
    pub hc_tests_mean: f64,
    pub hc_first_pass_tests_mean: f64,
    /// HC's first-pass tests over CHC's tests: the median over walks and the largest.
    pub first_pass_to_chc: Option<f64>,
    pub first_pass_to_chc_worst: Option<f64>,
    /// CHC's median frame over this mode's: the median over walks and the smallest.
    pub speedup_over_chc: Option<f64>,
    pub speedup_over_chc_worst: Option<f64>,
}

/// Each size, tau and mode of `runs` over its walks, in the order they first appear.
pub fn over_walks(runs: &[Row]) -> Vec<OverWalks> {
    let mut keys: Vec<(u64, f64, Mode)> = Vec::new();
    for r in runs {
        if !keys.contains(&(r.triangles, r.tau, r.mode)) {
            keys.push((r.triangles, r.tau, r.mode));
        }
    }
    keys.into_iter().filter_map(|(triangles, tau, mode)| over(runs, triangles, tau, mode)).collect()
}

fn over(runs: &[Row], triangles: u64, tau: f64, mode: Mode) -> Option<OverWalks> {
    let ok = |r: &&Row| r.triangles == triangles && r.tau == tau && r.error.is_none();
    let walks: Vec<&Row> = runs.iter().filter(ok).filter(|r| r.mode == mode).collect();
    if walks.is_empty() {
        return None;
    }
    let chc = |w: u32| runs.iter().filter(ok).find(|r| r.mode == Mode::Chc && r.walk == w);
    let median = |f: fn(&Row) -> f64| quantile(&walks.iter().map(|r| f(r)).collect::<Vec<_>>(), 0.5);
    let first_pass: Vec<f64> = walks
        .iter()
        .filter_map(|r| chc(r.walk).filter(|c| c.hc_tests_mean > 0.0).map(|c| r.hc_first_pass_tests_mean / c.hc_tests_mean))
        .collect();
    let speedup: Vec<f64> = walks
        .iter()
        .filter_map(|r| chc(r.walk).filter(|_| r.frame_ms_median > 0.0).map(|c| c.frame_ms_median / r.frame_ms_median))
        .collect();
    let some = |v: &[f64], q: f64| (!v.is_empty()).then(|| quantile(v, q));
    Some(OverWalks {
        triangles,
        mode,
        tau,
        walks: walks.len() as u32,
        frame_ms_median: median(|r| r.frame_ms_median),
        frame_ms_worst: walks.iter().map(|r| r.frame_ms_median).fold(0.0, f64::max),
        hc_tests_mean: median(|r| r.hc_tests_mean),
        hc_first_pass_tests_mean: median(|r| r.hc_first_pass_tests_mean),
        first_pass_to_chc: some(&first_pass, 0.5),
        first_pass_to_chc_worst: some(&first_pass, 1.0),
        speedup_over_chc: some(&speedup, 0.5),
        speedup_over_chc_worst: some(&speedup, 0.0),
    })
}

/// A sweep and how it ran, for its tables and curves.
pub struct Report<'a> {
    pub sweep: &'a Sweep,
    pub taus: &'a [f64],
    pub modes: &'a [Mode],
    pub cost_adaptive: bool,
}

/// A table column: its header and how a run fills it.
type Column = (&'static str, fn(&Row) -> String);

const COLUMNS: [Column; 13] = [
    ("frame ms", |r| format!("{:.1}", r.frame_ms_median)),
    ("CPU ms", |r| format!("{:.1}", r.cpu_ms_median)),
    ("p95 ms", |r| format!("{:.1}", r.frame_ms_p95)),
    ("OR ms", |r| format!("{:.1}", r.or_ms_median)),
    ("HC ms", |r| format!("{:.1}", r.hc_ms_median)),
    ("RVG ms", |r| format!("{:.1}", r.rvg_ms_median)),
    ("HC tests", |r| format!("{:.0}", r.hc_tests_mean)),
    ("first pass", |r| format!("{:.0}", r.hc_first_pass_tests_mean)),
    ("retests", |r| format!("{:.0}", r.hc_retests_mean)),
    ("traversal: V(i-1) / siblings / new", |r| r.hc_tests_where.map_or("-".into(), |w| format!("{:.0} / {:.0} / {:.0}", w[0], w[1], w[2]))),
    ("triangles drawn", |r| format!("{:.0}", r.triangles_drawn_mean)),
    ("PVS nodes", |r| format!("{:.0}", r.pvs_nodes_mean)),
    ("peak MB", |r| r.peak_rss_kb.values().map(|kb| format!("{:.0}", *kb as f64 * 1.024e-3)).collect::<Vec<_>>().join(" / ")),
];

impl Report<'_> {
    pub fn markdown(&self) -> String {
        let s = self.sweep;
        let mut out = format!("# Scale: the generated plant, {} walks of {} frames at {}\n\n", s.walks, s.frames, s.size);
        out.push_str("| plant | triangles | build s | build peak GB | file GB |\n| --- | --- | --- | --- | --- |\n");
        for sc in &s.scenes {
            let (peak_gb, file_gb) = (sc.build_peak_rss_kb as f64 * 1.024e-6, sc.file_bytes as f64 / 1e9);
            let _ = writeln!(out, "| {} | {} | {:.1} | {peak_gb:.2} | {file_gb:.2} |", sc.label, sc.triangles, sc.build_seconds);
        }
        for &tau in self.taus {
            self.over_walks_table(&mut out, tau);
            self.runs_table(&mut out, tau);
        }
        out.push_str(
            "\nOver walks: the median over the walks of each figure and the worst walk's; ratios walk by walk against CHC's run of \
             the same walk. CPU ms: CPU time of the median frame, all threads of every process (lavapipe draws on the CPU); the \
             switch's three processes share this host's cores. first pass: HC's tests before its retests; CHC tests in one pass. \
             peak MB: one figure per process (render; display / node a / node b for the switch).\n",
        );
        if !self.cost_adaptive {
            out.push_str(
                "Every mode culled every frame (`--cost-adaptive` lets prev and the switch skip culling where it does not pay).\n",
            );
        }
        out
    }

    fn over_walks_table(&self, out: &mut String, tau: f64) {
        let _ = write!(
            out,
            "\n## tau {tau}, over {} walks\n\n| plant | mode | walks | frame ms | worst walk's | first pass / CHC's | worst walk's | \
             CHC / mode frame | worst walk's |\n|{}\n",
            self.sweep.walks,
            " --- |".repeat(9)
        );
        let x = |v: Option<f64>, unit: &str| v.map_or("–".into(), |v| format!("{v:.2}{unit}"));
        for o in self.sweep.over_walks.iter().filter(|o| o.tau == tau) {
            let _ = writeln!(
                out,
                "| {} | {} | {} | {:.1} | {:.1} | {} | {} | {} | {} |",
                label(o.triangles),
                o.mode,
                o.walks,
                o.frame_ms_median,
                o.frame_ms_worst,
                x(o.first_pass_to_chc, "x"),
                x(o.first_pass_to_chc_worst, "x"),
                x(o.speedup_over_chc, "x"),
                x(o.speedup_over_chc_worst, "x"),
            );
        }
    }

    fn runs_table(&self, out: &mut String, tau: f64) {
        let s = self.sweep;
        let _ = write!(
            out,
            "\n### tau {tau}, each walk\n\n| plant | walk | mode | {} | vfc / mode | first pass / CHC's | retests / CHC's tests |\n|{}\n",
            COLUMNS.map(|c| c.0).join(" | "),
            " --- |".repeat(COLUMNS.len() + 6)
        );
        for r in s.runs.iter().filter(|r| r.tau == tau) {
            let of = |m: Mode| {
                s.runs.iter().find(|o| (o.triangles, o.walk, o.tau, o.mode) == (r.triangles, r.walk, tau, m) && o.error.is_none())
            };
            let cells: Vec<String> = match &r.error {
                Some(_) => vec!["failed".into(); COLUMNS.len()],
                None => COLUMNS.iter().map(|c| c.1(r)).collect(),
            };
            let ratio = match of(Mode::Vfc) {
                Some(v) if r.error.is_none() && r.frame_ms_median > 0.0 => format!("{:.2}", v.frame_ms_median / r.frame_ms_median),
                _ => "–".into(),
            };
            // CHC tests in one pass: its tests are what HC's first pass is held to.
            let to_chc = |n: f64| match of(Mode::Chc) {
                Some(c) if r.error.is_none() && r.hc_tests_mean > 0.0 && c.hc_tests_mean > 0.0 => format!("{:.2}x", n / c.hc_tests_mean),
                _ => "–".into(),
            };
            let (first, again) = (to_chc(r.hc_first_pass_tests_mean), to_chc(r.hc_retests_mean));
            let _ =
                writeln!(out, "| {} | {} | {} | {} | {ratio} | {first} | {again} |", label(r.triangles), r.walk, r.mode, cells.join(" | "));
        }
    }

    /// Frame time and HC tests against scene triangles at the first tau, medians over walks.
    pub fn charts(&self) -> Vec<Chart<'static>> {
        let tau = self.taus[0];
        let series = |y: fn(&OverWalks) -> f64| -> Vec<Series> {
            self.modes
                .iter()
                .map(|m| {
                    let at: Vec<&OverWalks> = self.sweep.over_walks.iter().filter(|o| o.mode == *m && o.tau == tau && y(o) > 0.0).collect();
                    Series {
                        name: m.to_string(),
                        points: at.iter().map(|o| (o.triangles as f64, y(o))).collect(),
                        point_labels: at.iter().map(|o| label(o.triangles)).collect(),
                        bold: false,
                    }
                })
                .collect()
        };
        vec![
            Chart {
                title: "Frame time against scene size (median over walks)",
                x: "scene triangles",
                y: "frame ms, median",
                series: series(|o| o.frame_ms_median),
            },
            Chart {
                title: "HC tests a frame against scene size (median over walks)",
                x: "scene triangles",
                y: "box tests a frame, mean",
                series: series(|o| o.hc_tests_mean),
            },
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(walk: u32, mode: Mode, frame_ms: f64, tests: f64, first: f64) -> Row {
        Row {
            triangles: 2_000_000,
            walk,
            mode,
            tau: 1.0,
            frame_ms_median: frame_ms,
            hc_tests_mean: tests,
            hc_first_pass_tests_mean: first,
            ..Row::default()
        }
    }

    #[test]
    fn ratios_are_taken_walk_by_walk_and_the_worst_walk_kept() {
        let runs = [
            run(1, Mode::Chc, 40.0, 600.0, 600.0),
            run(1, Mode::Prev, 20.0, 800.0, 660.0),
            run(2, Mode::Chc, 30.0, 500.0, 500.0),
            run(2, Mode::Prev, 25.0, 700.0, 650.0),
            run(3, Mode::Chc, 50.0, 400.0, 400.0),
            run(3, Mode::Prev, 20.0, 600.0, 400.0),
            // A failed run counts in no figure.
            Row { error: Some("failed".into()), ..run(4, Mode::Prev, 1.0, 1.0, 1.0) },
        ];
        let o = over_walks(&runs);
        assert_eq!(o.len(), 2);
        let prev = &o[1];
        assert_eq!((prev.mode, prev.walks), (Mode::Prev, 3));
        assert_eq!((prev.frame_ms_median, prev.frame_ms_worst), (20.0, 25.0));
        // First pass over CHC's tests: 1.1, 1.3, 1.0.
        let close = |v: Option<f64>, want: f64| v.is_some_and(|v| (v - want).abs() < 1e-12);
        assert!(close(prev.first_pass_to_chc, 1.1) && close(prev.first_pass_to_chc_worst, 1.3), "{prev:?}");
        // CHC's frame over prev's: 2.0, 1.2, 2.5.
        assert!(close(prev.speedup_over_chc, 2.0) && close(prev.speedup_over_chc_worst, 1.2), "{prev:?}");
        assert!(close(o[0].first_pass_to_chc, 1.0), "{:?}", o[0]);
    }
}
