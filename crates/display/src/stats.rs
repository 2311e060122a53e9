//! What the display writes: one row per displayed frame (stats.csv), the run's summary
//! (summary.json, [`osw_render::results`]), and pvs.txt.

use crate::Args;
use crate::links::Cluster;
use osw_render::Mode;
use osw_render::results::{self, Details, DisplayFrame, Summary, SwitchSummary};
use osw_render::stats::{FrameStats, quantile};
use osw_wire::config::Settings;

pub fn write_outputs(
    a: &Args,
    set: &Settings,
    scene: &osw_scene::SceneFile,
    rows: &[DisplayFrame],
    pvs: &str,
    cluster: &Cluster,
    residency: &osw_gpu::residency::ResidencyStats,
) -> anyhow::Result<()> {
    let clocks = &cluster.clocks;
    let degraded: Vec<u64> = rows.iter().filter(|r| r.degraded == 1).map(|r| r.frame).collect();
    let (w, h) = set.size;
    let col = |f: fn(&DisplayFrame) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let mean = |f: fn(&DisplayFrame) -> f64| osw_render::stats::mean(rows.iter().map(f));
    // The first frame waits for start-up: frame times from the second on.
    let frame_ms: Vec<f64> = rows.iter().skip(1).map(|r| r.frame_ms).collect();
    let in_frames = |ms: f64| ms / quantile(&frame_ms, 0.5).max(f64::MIN_POSITIVE);
    let floor_ms = results::latency_floor_ms(rows);
    let ids_sent: f64 = rows.iter().map(|r| r.ids_sent as f64).sum();
    let ids_full: f64 = rows.iter().map(|r| r.ids_full as f64).sum();
    let bytes: f64 = rows.iter().map(|r| r.bytes as f64).sum();
    let id_bytes: f64 = rows.iter().map(|r| r.id_bytes as f64).sum();
    // The keys every run has, as one GPU's run has them.
    let frames: Vec<FrameStats> = rows.iter().map(FrameStats::from).collect();
    let s = Summary {
        mode: Mode::Switch,
        tau: set.tau,
        frame_ms_median: quantile(&frame_ms, 0.5),
        frame_ms_p95: quantile(&frame_ms, 0.95),
        scene: set.scene.display().to_string(),
        scene_hash: osw_scene::format::hash_hex(scene.content_hash()),
        path: a.path.as_ref().map_or("(interactive walk)".into(), |p| p.display().to_string()),
        width: w,
        height: h,
        textures: results::textures_key(scene, !a.no_textures),
        of: Details::Switch(SwitchSummary {
            bytes_per_frame_mean: mean(|r| r.bytes as f64),
            ids_sent_mean: mean(|r| r.ids_sent as f64),
            ids_full_mean: mean(|r| r.ids_full as f64),
            incremental_saved_fraction: if ids_full > 0.0 { 1.0 - ids_sent / ids_full } else { 0.0 },
            bytes_per_id: bytes / ids_sent.max(1.0),
            id_bytes_per_id: id_bytes / ids_sent.max(1.0),
            mask_bytes_per_frame_mean: mean(|r| r.mask_bytes as f64),
            batch: set.batch,
            latency_ms_median: quantile(&col(|r| r.latency_ms), 0.5),
            rvg_gpu_ms_median: osw_render::stats::gpu_median(rows.iter().map(|r| r.rvg_gpu_ms)),
            latency_ms_p95: quantile(&col(|r| r.latency_ms), 0.95),
            latency_ms_max: quantile(&col(|r| r.latency_ms), 1.0),
            latency_frames_median: in_frames(quantile(&col(|r| r.latency_ms), 0.5)),
            latency_frames_p95: in_frames(quantile(&col(|r| r.latency_ms), 0.95)),
            latency_frames_max: in_frames(quantile(&col(|r| r.latency_ms), 1.0)),
            latency_floor_ms: floor_ms,
            latency_floor_frames: in_frames(floor_ms),
            camera_link_ms_median: quantile(&col(|r| r.camera_link_ms), 0.5),
            eof_link_ms_median: quantile(&col(|r| r.eof_link_ms), 0.5),
            // The last frame's end of frame reaches no OR: it has no peer latency.
            peer_link_ms_median: quantile(&rows[..rows.len().saturating_sub(1)].iter().map(|r| r.peer_link_ms).collect::<Vec<_>>(), 0.5),
            node_losses: cluster.losses,
            node_rejoins: cluster.rejoins,
            auth_refusals: osw_wire::net::auth_refusals(),
            evictions: residency.evictions,
            wire_bytes_per_frame_mean: osw_wire::net::wire_bytes_sent() as f64 / rows.len().max(1) as f64,
            degraded_frames: degraded.len() as u64,
            degraded_first_frame: degraded.first().copied(),
            degraded_last_frame: degraded.last().copied(),
            clock_offset_a_us: clocks[0].offset_us,
            clock_offset_b_us: clocks[1].offset_us,
            clock_rtt_a_us: clocks[0].rtt_us,
            clock_rtt_b_us: clocks[1].rtt_us,
            // `osw run` merges in the nodes' own statistics.
            ..SwitchSummary::default()
        }),
        ..Summary::of(&frames)
    };
    s.write(&a.out)?;
    std::fs::write(a.out.join("pvs.txt"), pvs)?;
    results::csv::write(&a.out.join("stats.csv"), rows)?;
    Ok(())
}
