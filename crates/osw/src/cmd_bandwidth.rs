//! `osw bandwidth`: bytes and ids per frame on each link of a switch run (`osw run`), next to
//! occlusion switch's model (sec. 3.5): 8n + nh/b + 3(72 + h) bytes a frame, for n ids sent, h bytes
//! of header per packet and b ids per packet; with a `--full` run beside it, the saving of
//! incremental transmission and a plot of both over the frames (the form of fig. 3).
//!
//! The model is the paper's as written, with this run's n, h and b: it counts 4 bytes an id
//! on each of the two links HC sends on, headers as if on one link, and ⌈n/b⌉ packets. The
//! switch sends ⌈max(added, removed)/b⌉ deltas plus an end of frame on both links, and codes
//! ids in about 1-2 bytes: the measured columns are what crossed the sockets.
//!
//! With `--exact` (`osw exact` of the same path), the saving that sending exactly the visible
//! leaves would get: leaves entering and leaving exact visibility over its size. Leaves, not
//! LOD nodes: a leaf that stays visible and changes LOD costs the run two ids and exact
//! visibility none, so this is what the walk itself changes, not a bound on the run.

use crate::plot::{Chart, Series};
use anyhow::bail;
use osw_render::results::{self, DisplayFrame, NodeFrame, Summary};
use osw_render::stats::mean;
use osw_wire::{CameraPacket, Delta, IdList, Message};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// A line of bandwidth.csv: a frame's ids and bytes on each link, measured and by the paper's
/// model; the same of the run with whole sets, where given.
#[derive(serde::Serialize, Default)]
struct BandwidthRow {
    frame: usize,
    ids_sent: u64,
    visible: u64,
    batches: u64,
    hc_to_rvg_bytes: u64,
    hc_to_or_bytes: u64,
    rvg_camera_bytes: u64,
    total_bytes: u64,
    model_bytes: f64,
    full_ids_sent: Option<u64>,
    full_total_bytes: Option<u64>,
    full_model_bytes: Option<f64>,
}

#[derive(clap::Args)]
pub struct Args {
    /// A switch run's directory (`osw run`: stats.csv, node-a.csv, node-b.csv, summary.json).
    #[arg(long)]
    run: PathBuf,
    /// The same walk run with `osw run --full` (whole visible set every frame).
    #[arg(long)]
    full: Option<PathBuf>,
    /// `osw exact` output of the same path (exact_leaves.txt): the saving that sending exactly
    /// the visible leaves would get (leaves entering and leaving; LOD switches not counted).
    #[arg(long)]
    exact: Option<PathBuf>,
    /// Output directory: bandwidth.csv, bandwidth.json, bandwidth_ids.png/.svg,
    /// bandwidth_bytes.png/.svg.
    #[arg(long)]
    out: PathBuf,
}

/// One run's traffic per frame.
struct Traffic {
    ids: Vec<f64>,
    visible: Vec<f64>,
    batches: Vec<f64>,
    hc_to_rvg: Vec<f64>,
    hc_to_or: Vec<f64>,
    /// RVG sends each frame's camera to both nodes (not counted by the nodes: computed).
    rvg_cameras: f64,
    /// The paper's h: a packet's header (length prefix, message tag, frame number, list
    /// lengths: an empty delta) and b.
    header: f64,
    batch: f64,
    frame_ms_median: f64,
}

impl Traffic {
    fn read(dir: &Path) -> anyhow::Result<Traffic> {
        let summary = Summary::read(dir)?;
        let Some(sw) = summary.switch() else { bail!("{} is not a switch run (osw run): its mode is {}", dir.display(), summary.mode) };
        let display: Vec<DisplayFrame> = results::csv::read(&dir.join("stats.csv"))?;
        let frames = display.len();
        // Each frame's HC node sent it: the two nodes' rows added by frame.
        let (mut batches, mut hc_to_rvg, mut hc_to_or) = (vec![0.0; frames], vec![0.0; frames], vec![0.0; frames]);
        for node in ["node-a.csv", "node-b.csv"] {
            let path = dir.join(node);
            for f in results::csv::read::<NodeFrame>(&path)? {
                let Some(k) = usize::try_from(f.frame).ok().filter(|&k| k < frames) else {
                    bail!("{}: frame {}: not a frame of this run ({frames} frames)", path.display(), f.frame)
                };
                batches[k] += f.batches as f64;
                hc_to_rvg[k] += f.bytes_to_display as f64;
                hc_to_or[k] += f.bytes_to_peer as f64;
            }
        }
        let camera = Message::Camera(CameraPacket {
            frame: frames as u64,
            position: [0.0; 3],
            orientation: [0.0, 0.0, 0.0, 1.0],
            fovy_deg: 60.0,
            tau_px: 0.0,
            sampled_us: osw_wire::clock::now_us(),
        });
        let empty = Message::Delta(Delta { frame: frames as u64, added: IdList::default(), removed: IdList::default() });
        Ok(Traffic {
            ids: display.iter().map(|f| f.ids_sent as f64).collect(),
            visible: display.iter().map(|f| f.ids_full as f64).collect(),
            batches,
            hc_to_rvg,
            hc_to_or,
            rvg_cameras: 2.0 * osw_wire::Frame::new(&camera)?.len() as f64,
            header: osw_wire::Frame::new(&empty)?.len() as f64,
            batch: sw.batch as f64,
            frame_ms_median: summary.frame_ms_median,
        })
    }

    fn total(&self, i: usize) -> f64 {
        self.hc_to_rvg[i] + self.hc_to_or[i] + self.rvg_cameras
    }

    /// Paper 000 sec. 3.5 with this run's n, h and b.
    fn model(&self, i: usize) -> f64 {
        let (n, h, b) = (self.ids[i], self.header, self.batch);
        8.0 * n + n * h / b + 3.0 * (72.0 + h)
    }
}

#[derive(Serialize)]
struct Side {
    ids_sent_mean: f64,
    bytes_per_frame_mean: f64,
    hc_to_rvg_bytes_mean: f64,
    hc_to_or_bytes_mean: f64,
    rvg_camera_bytes: f64,
    model_bytes_per_frame_mean: f64,
    header_bytes: f64,
    batch: f64,
    /// At the run's median frame rate.
    megabits_per_second: f64,
}

fn side(t: &Traffic) -> Side {
    let n = t.ids.len();
    let total: Vec<f64> = (0..n).map(|i| t.total(i)).collect();
    let ids = mean(t.ids.iter().copied());
    let bytes = mean(total.iter().copied());
    Side {
        ids_sent_mean: ids,
        bytes_per_frame_mean: bytes,
        hc_to_rvg_bytes_mean: mean(t.hc_to_rvg.iter().copied()),
        hc_to_or_bytes_mean: mean(t.hc_to_or.iter().copied()),
        rvg_camera_bytes: t.rvg_cameras,
        model_bytes_per_frame_mean: mean((0..n).map(|i| t.model(i))),
        header_bytes: t.header,
        batch: t.batch,
        megabits_per_second: if t.frame_ms_median > 0.0 { bytes * 8.0 / 1e6 * (1000.0 / t.frame_ms_median) } else { 0.0 },
    }
}

#[derive(Serialize)]
struct Report {
    frames: usize,
    incremental: Side,
    full: Option<Side>,
    /// 1 - bytes with deltas / bytes with the whole set, per frame means.
    saved_fraction_bytes: Option<f64>,
    /// 1 - ids sent / visible-set size (the same run: what full transmission would send).
    saved_fraction_ids: f64,
    /// With `--exact`: 1 - leaves entering and leaving exact visibility / its size (LOD switches
    /// not counted: the churn of the walk itself).
    exact_saved_fraction_ids: Option<f64>,
}

/// Per frame, the leaves entering or leaving exact visibility (all of frame 0's, as the run
/// sends) and how many are visible.
fn exact_churn(dir: &Path, frames: usize) -> anyhow::Result<(Vec<f64>, Vec<f64>)> {
    let mut sets = osw_render::output::read_ids(&dir.join("exact_leaves.txt"))?;
    if sets.len() != frames {
        bail!("{} has {} frames, the run has {frames}", dir.display(), sets.len());
    }
    let (mut churn, mut size, mut previous) = (Vec::new(), Vec::new(), Vec::new());
    let (mut added, mut removed) = (Vec::new(), Vec::new());
    for set in &mut sets {
        set.sort_unstable();
        osw_cull::delta::diff(&previous, set, &mut added, &mut removed);
        churn.push((added.len() + removed.len()) as f64);
        size.push(set.len() as f64);
        previous = std::mem::take(set);
    }
    Ok((churn, size))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let inc = Traffic::read(&a.run)?;
    let full = a.full.as_deref().map(Traffic::read).transpose()?;
    let frames = match &full {
        Some(f) if f.ids.len() != inc.ids.len() => {
            bail!("{} has {} frames, {} has {}", a.run.display(), inc.ids.len(), a.full.as_ref().unwrap().display(), f.ids.len())
        }
        _ => inc.ids.len(),
    };
    let exact = a.exact.as_deref().map(|d| exact_churn(d, frames)).transpose()?;
    std::fs::create_dir_all(&a.out)?;
    let rows: Vec<BandwidthRow> = (0..frames)
        .map(|i| BandwidthRow {
            frame: i,
            ids_sent: inc.ids[i] as u64,
            visible: inc.visible[i] as u64,
            batches: inc.batches[i] as u64,
            hc_to_rvg_bytes: inc.hc_to_rvg[i] as u64,
            hc_to_or_bytes: inc.hc_to_or[i] as u64,
            rvg_camera_bytes: inc.rvg_cameras as u64,
            total_bytes: inc.total(i) as u64,
            model_bytes: inc.model(i),
            full_ids_sent: full.as_ref().map(|f| f.ids[i] as u64),
            full_total_bytes: full.as_ref().map(|f| f.total(i) as u64),
            full_model_bytes: full.as_ref().map(|f| f.model(i)),
        })
        .collect();
    results::csv::write(&a.out.join("bandwidth.csv"), &rows)?;
    let report = Report {
        frames,
        saved_fraction_bytes: full
            .as_ref()
            .map(|f| 1.0 - mean((0..frames).map(|i| inc.total(i))) / mean((0..frames).map(|i| f.total(i))).max(1.0)),
        saved_fraction_ids: 1.0 - inc.ids.iter().sum::<f64>() / inc.visible.iter().sum::<f64>().max(1.0),
        exact_saved_fraction_ids: exact.as_ref().map(|(churn, size)| 1.0 - churn.iter().sum::<f64>() / size.iter().sum::<f64>().max(1.0)),
        incremental: side(&inc),
        full: full.as_ref().map(side),
    };
    std::fs::write(a.out.join("bandwidth.json"), serde_json::to_string_pretty(&report)?)?;

    let over_frames = |v: &dyn Fn(usize) -> f64| (0..frames).map(|i| (i as f64, v(i))).collect::<Vec<_>>();
    let series = |name: &str, points| Series { name: name.into(), points, point_labels: vec![], bold: false };
    let mut ids = vec![
        series("incremental (ids added + removed)", over_frames(&|i| inc.ids[i])),
        series("full (visible set)", over_frames(&|i| inc.visible[i])),
    ];
    if let Some(f) = &full {
        ids.push(series("--full run", over_frames(&|i| f.ids[i])));
    }
    if let Some((churn, _)) = &exact {
        ids.push(series("exact visibility: leaves entering + leaving (no LOD switches)", over_frames(&|i| churn[i])));
    }
    crate::plot::write(
        &Chart { title: "Node ids per frame, incremental and full (occlusion switch fig. 3)", x: "frame", y: "ids", series: ids },
        &a.out.join("bandwidth_ids"),
    )?;
    let mut bytes = vec![
        series("incremental, measured", over_frames(&|i| inc.total(i))),
        series("incremental, paper's model", over_frames(&|i| inc.model(i))),
    ];
    if let Some(f) = &full {
        bytes.push(series("full, measured", over_frames(&|i| f.total(i))));
        bytes.push(series("full, paper's model", over_frames(&|i| f.model(i))));
    }
    crate::plot::write(
        &Chart { title: "Bytes per frame on all links", x: "frame", y: "bytes", series: bytes },
        &a.out.join("bandwidth_bytes"),
    )?;
    out!(
        "bandwidth: {:.0} bytes a frame with deltas (model {:.0}){}, {:.1}% of ids saved{} → {}",
        report.incremental.bytes_per_frame_mean,
        report.incremental.model_bytes_per_frame_mean,
        report.full.as_ref().map_or(String::new(), |f| format!(
            ", {:.0} with the whole set ({:.1}% saved)",
            f.bytes_per_frame_mean,
            report.saved_fraction_bytes.unwrap_or(0.0) * 100.0
        )),
        report.saved_fraction_ids * 100.0,
        report.exact_saved_fraction_ids.map_or(String::new(), |e| format!(" (exact visibility, leaves only: {:.1}%)", e * 100.0)),
        a.out.display()
    );
    Ok(())
}
