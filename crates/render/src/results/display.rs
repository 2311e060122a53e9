//! The display's frames (the switch run's `stats.csv`), written by `osw-display` and read by
//! `osw bandwidth`, `osw latency`, `osw scale` and `osw compare`.

use serde::{Deserialize, Serialize};

/// One displayed frame.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct DisplayFrame {
    pub frame: u64,
    /// Time from the previous displayed frame to this one.
    pub frame_ms: f64,
    /// RVG's gather and submit of this frame's draw, which waits for the draw before it (the
    /// display keeps one draw in flight: `osw_gpu::RenderOptions::overlap`).
    pub rvg_ms: f64,
    /// RVG's draw on the GPU, from timestamps (`osw-display --gpu-times`); empty otherwise.
    pub rvg_gpu_ms: Option<f64>,
    /// The HC node's time on the frame (OR first when it ran alone, HC, sending), and HC's
    /// passes (osw_render::pass::hc).
    pub hc_ms: f64,
    pub hc_traversal_ms: f64,
    pub hc_second_look_ms: f64,
    pub hc_retest_ms: f64,
    pub latency_ms: f64,
    /// One-way latency of each link, from wall-clock stamps corrected by the estimated clock
    /// offsets: RVG → HC (this frame's camera), HC → RVG (its end of frame), HC → OR (its
    /// end of frame to the peer; filled in once the peer reports it, a frame later).
    pub camera_link_ms: f64,
    pub eof_link_ms: f64,
    pub peer_link_ms: f64,
    /// The node the frame came from, and 1 when one node made it alone (the other down, or
    /// their link cut).
    pub hc_node: u32,
    pub degraded: u32,
    /// Resident memory once the frame is shown (a soak shows it flat), and of it the
    /// anonymous memory (not the mapped scene's pages).
    pub rss_kb: u64,
    #[serde(default)]
    pub anon_kb: u64,
    /// CPU time of the display's process since the previous frame, all threads.
    pub cpu_ms: f64,
    pub bytes: u64,
    /// Of `bytes`, the messages that carry ids (deltas, keyframes), their headers included.
    pub id_bytes: u64,
    /// Of `bytes`, HC's cluster mask (osw_wire::messages::ClusterMask), its header included.
    #[serde(default)]
    pub mask_bytes: u64,
    pub ids_sent: u64,
    pub ids_full: u64,
    pub pvs_nodes: u32,
    pub triangles_drawn: u64,
    pub tests: u32,
    /// 1 when HC frustum culled only (cost-adaptive culling).
    pub cull_skipped: u32,
    /// RVG's cluster tests (as `osw render`'s stats.csv).
    pub clusters: u64,
    pub clusters_frustum_culled: u64,
    pub clusters_cone_culled: u64,
    pub clusters_occlusion_culled: u64,
    pub triangles_backface_culled: u64,
    pub triangles_small_culled: u64,
}
