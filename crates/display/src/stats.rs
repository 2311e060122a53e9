//! What the display writes: one row per displayed frame (stats.csv), the run's summary
//! (summary.json, the GPU issue's keys and the switch's), and pvs.txt.

use crate::Args;
use crate::links::Cluster;
use osw_render::stats::quantile;
use osw_wire::config::Settings;
use serde::Serialize;

/// One displayed frame.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct FrameRow {
    pub frame: u64,
    /// Time from the previous displayed frame to this one.
    pub frame_ms: f64,
    pub rvg_ms: f64,
    pub hc_ms: f64,
    pub latency_ms: f64,
    /// One-way latency of each link, from wall-clock stamps corrected by the estimated clock
    /// offsets: RVG → HC (this frame's camera), HC → RVG (its end of frame), HC → OR (its
    /// end of frame to the peer; filled in once the peer reports it, a frame later).
    pub camera_link_ms: f64,
    pub eof_link_ms: f64,
    pub peer_link_ms: f64,
    /// The node the frame came from, and 1 when a node was down (the other ran alone).
    pub hc_node: u32,
    pub degraded: u32,
    /// Resident memory once the frame is shown (a soak shows it flat).
    pub rss_kb: u64,
    pub bytes: u64,
    /// Of `bytes`, the messages that carry ids (deltas, keyframes), their headers included.
    pub id_bytes: u64,
    pub ids_sent: u64,
    pub ids_full: u64,
    pub pvs_nodes: u32,
    pub triangles_drawn: u64,
    pub tests: u32,
    /// RVG's cluster tests (as `osw render`'s stats.csv).
    pub clusters: u64,
    pub clusters_frustum_culled: u64,
    pub clusters_cone_culled: u64,
    pub clusters_occlusion_culled: u64,
}

#[derive(Serialize, Default)]
struct Summary {
    mode: String,
    tau: f64,
    frames: u64,
    frame_ms_median: f64,
    frame_ms_p95: f64,
    triangles_drawn_mean: f64,
    pvs_nodes_mean: f64,
    tests_mean: f64,
    clusters_mean: f64,
    clusters_frustum_culled_fraction: f64,
    clusters_cone_culled_fraction: f64,
    clusters_occlusion_culled_fraction: f64,
    bytes_per_frame_mean: f64,
    ids_sent_mean: f64,
    ids_full_mean: f64,
    incremental_saved_fraction: f64,
    bytes_per_id: f64,
    /// Bytes of the id-carrying messages per id sent: paper 000 sec. 3.5's 4 bytes an id plus
    /// packet headers, without the camera and end of frame that every frame sends anyway.
    id_bytes_per_id: f64,
    /// Ids per delta batch, the paper's b.
    batch: usize,
    latency_ms_median: f64,
    latency_ms_p95: f64,
    latency_ms_max: f64,
    camera_link_ms_median: f64,
    eof_link_ms_median: f64,
    peer_link_ms_median: f64,
    /// Node a's and b's clock minus the display's, and the round trip of the probe used.
    /// Failover (issue 6): node connections lost and made again, frames made by one node
    /// alone, and the first and last of them.
    node_losses: u32,
    node_rejoins: u32,
    degraded_frames: u64,
    degraded_first_frame: Option<u64>,
    degraded_last_frame: Option<u64>,
    clock_offset_a_us: f64,
    clock_offset_b_us: f64,
    clock_rtt_a_us: f64,
    clock_rtt_b_us: f64,
    hc_ms_median: f64,
    rvg_ms_median: f64,
    scene: String,
    scene_hash: String,
    path: String,
    width: u32,
    height: u32,
}

pub fn write_outputs(
    a: &Args,
    set: &Settings,
    scene: &osw_scene::SceneFile,
    rows: &[FrameRow],
    pvs: &str,
    cluster: &Cluster,
) -> anyhow::Result<()> {
    let clocks = &cluster.clocks;
    let degraded: Vec<u64> = rows.iter().filter(|r| r.degraded == 1).map(|r| r.frame).collect();
    let (w, h) = set.size;
    let col = |f: fn(&FrameRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let mean = |f: fn(&FrameRow) -> f64| col(f).iter().sum::<f64>() / rows.len().max(1) as f64;
    // The first frame waits for start-up: frame times from the second on.
    let frame_ms: Vec<f64> = rows.iter().skip(1).map(|r| r.frame_ms).collect();
    let ids_sent: f64 = rows.iter().map(|r| r.ids_sent as f64).sum();
    let ids_full: f64 = rows.iter().map(|r| r.ids_full as f64).sum();
    let bytes: f64 = rows.iter().map(|r| r.bytes as f64).sum();
    let id_bytes: f64 = rows.iter().map(|r| r.id_bytes as f64).sum();
    let clusters = rows.iter().map(|r| r.clusters).sum::<u64>().max(1) as f64;
    let share = |f: fn(&FrameRow) -> u64| rows.iter().map(f).sum::<u64>() as f64 / clusters;
    let s = Summary {
        mode: "switch".into(),
        tau: set.tau,
        frames: rows.len() as u64,
        frame_ms_median: quantile(&frame_ms, 0.5),
        frame_ms_p95: quantile(&frame_ms, 0.95),
        triangles_drawn_mean: mean(|r| r.triangles_drawn as f64),
        pvs_nodes_mean: mean(|r| r.pvs_nodes as f64),
        tests_mean: mean(|r| r.tests as f64),
        clusters_mean: mean(|r| r.clusters as f64),
        clusters_frustum_culled_fraction: share(|r| r.clusters_frustum_culled),
        clusters_cone_culled_fraction: share(|r| r.clusters_cone_culled),
        clusters_occlusion_culled_fraction: share(|r| r.clusters_occlusion_culled),
        bytes_per_frame_mean: mean(|r| r.bytes as f64),
        ids_sent_mean: mean(|r| r.ids_sent as f64),
        ids_full_mean: mean(|r| r.ids_full as f64),
        incremental_saved_fraction: if ids_full > 0.0 { 1.0 - ids_sent / ids_full } else { 0.0 },
        bytes_per_id: bytes / ids_sent.max(1.0),
        id_bytes_per_id: id_bytes / ids_sent.max(1.0),
        batch: set.batch,
        latency_ms_median: quantile(&col(|r| r.latency_ms), 0.5),
        latency_ms_p95: quantile(&col(|r| r.latency_ms), 0.95),
        latency_ms_max: quantile(&col(|r| r.latency_ms), 1.0),
        camera_link_ms_median: quantile(&col(|r| r.camera_link_ms), 0.5),
        eof_link_ms_median: quantile(&col(|r| r.eof_link_ms), 0.5),
        // The last frame's end of frame reaches no OR: it has no peer latency.
        peer_link_ms_median: quantile(&rows[..rows.len().saturating_sub(1)].iter().map(|r| r.peer_link_ms).collect::<Vec<_>>(), 0.5),
        node_losses: cluster.losses,
        node_rejoins: cluster.rejoins,
        degraded_frames: degraded.len() as u64,
        degraded_first_frame: degraded.first().copied(),
        degraded_last_frame: degraded.last().copied(),
        clock_offset_a_us: clocks[0].offset_us,
        clock_offset_b_us: clocks[1].offset_us,
        clock_rtt_a_us: clocks[0].rtt_us,
        clock_rtt_b_us: clocks[1].rtt_us,
        hc_ms_median: quantile(&col(|r| r.hc_ms), 0.5),
        rvg_ms_median: quantile(&col(|r| r.rvg_ms), 0.5),
        scene: set.scene.display().to_string(),
        scene_hash: osw_scene::format::hash_hex(scene.content_hash()),
        path: a.path.as_ref().map_or("(interactive walk)".into(), |p| p.display().to_string()),
        width: w,
        height: h,
    };
    std::fs::write(a.out.join("summary.json"), serde_json::to_string_pretty(&s)?)?;
    std::fs::write(a.out.join("pvs.txt"), pvs)?;
    let mut csv = String::from(
        "frame,frame_ms,rvg_ms,hc_ms,latency_ms,camera_link_ms,eof_link_ms,peer_link_ms,hc_node,degraded,rss_kb,bytes,id_bytes,ids_sent,ids_full,pvs_nodes,triangles_drawn,tests,clusters,clusters_frustum_culled,clusters_cone_culled,clusters_occlusion_culled\n",
    );
    for r in rows {
        csv.push_str(&format!(
            "{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.frame,
            r.frame_ms,
            r.rvg_ms,
            r.hc_ms,
            r.latency_ms,
            r.camera_link_ms,
            r.eof_link_ms,
            r.peer_link_ms,
            r.hc_node,
            r.degraded,
            r.rss_kb,
            r.bytes,
            r.id_bytes,
            r.ids_sent,
            r.ids_full,
            r.pvs_nodes,
            r.triangles_drawn,
            r.tests,
            r.clusters,
            r.clusters_frustum_culled,
            r.clusters_cone_culled,
            r.clusters_occlusion_culled
        ));
    }
    std::fs::write(a.out.join("stats.csv"), csv)?;
    Ok(())
}
