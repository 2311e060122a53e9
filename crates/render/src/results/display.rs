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
    /// Where the rest of the latency went, on the HC node's clock (`osw latency` stacks them
    /// with the links): the camera's wait before OR took it; OR drawing V(i-1) and the peer's
    /// deltas of V(i-1)... until the peer's end of frame (the whole OR pass when the node ran
    /// alone); OR's work after it; HC (traversal and sends); HC's cluster notes. Then on the
    /// display: the frame's wait before RVG began, the read-back (without frames to write or
    /// show, the wait for the draw to end), and how long the display
    /// waited to hand the frame to its writer thread (0 while the writer keeps up; the write
    /// itself is off the latency's path).
    #[serde(default)]
    pub camera_wait_ms: f64,
    #[serde(default)]
    pub or_front_ms: f64,
    #[serde(default)]
    pub or_tail_ms: f64,
    #[serde(default)]
    pub hc_stage_ms: f64,
    #[serde(default)]
    pub notes_ms: f64,
    #[serde(default)]
    pub display_wait_ms: f64,
    #[serde(default)]
    pub readback_ms: f64,
    #[serde(default)]
    pub write_ms: f64,
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

/// A stage of a camera's way from its sample to its frame shown, in the order it passes them.
pub struct Stage {
    pub column: &'static str,
    pub what: &'static str,
    pub of: fn(&DisplayFrame) -> f64,
    /// A stage of work (or of a link) rather than a wait: in the floor.
    pub busy: bool,
}

pub const STAGES: [Stage; 10] = [
    Stage { column: "camera_link_ms", what: "RVG → HC node (camera)", of: |f| f.camera_link_ms, busy: true },
    Stage { column: "camera_wait_ms", what: "camera waits for OR", of: |f| f.camera_wait_ms, busy: false },
    Stage { column: "or_front_ms", what: "OR until the peer's end of frame", of: |f| f.or_front_ms, busy: true },
    Stage { column: "or_tail_ms", what: "OR after it", of: |f| f.or_tail_ms, busy: true },
    Stage { column: "hc_stage_ms", what: "HC", of: |f| f.hc_stage_ms, busy: true },
    Stage { column: "notes_ms", what: "HC's cluster notes", of: |f| f.notes_ms, busy: true },
    Stage { column: "eof_link_ms", what: "HC → RVG (end of frame)", of: |f| f.eof_link_ms, busy: true },
    Stage { column: "display_wait_ms", what: "frame waits for RVG", of: |f| f.display_wait_ms, busy: false },
    Stage { column: "rvg_ms", what: "RVG gather and draw", of: |f| f.rvg_ms, busy: true },
    Stage { column: "readback_ms", what: "read-back", of: |f| f.readback_ms, busy: true },
];

/// The latency a camera cannot go below with these stages' times: the sum of the median busy
/// stage times (without the camera's and the frame's waits, and without the frame's write).
pub fn latency_floor_ms(rows: &[DisplayFrame]) -> f64 {
    let median = |f: fn(&DisplayFrame) -> f64| crate::stats::quantile(&rows.iter().map(f).collect::<Vec<_>>(), 0.5);
    STAGES.iter().filter(|s| s.busy).map(|s| median(s.of)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_floor_sums_the_median_of_each_busy_stage_and_leaves_out_waits() {
        let row = |k: f64| DisplayFrame {
            camera_link_ms: k,
            camera_wait_ms: 100.0 * k,
            or_front_ms: 2.0 * k,
            or_tail_ms: 1.0,
            hc_stage_ms: 3.0,
            notes_ms: 0.5,
            eof_link_ms: 0.25,
            display_wait_ms: 50.0,
            rvg_ms: 4.0,
            readback_ms: 2.0,
            write_ms: 30.0,
            ..DisplayFrame::default()
        };
        // Medians: camera link 2, OR's front 4; the rest as set.
        let rows = [row(1.0), row(2.0), row(9.0)];
        assert_eq!(latency_floor_ms(&rows), 2.0 + 4.0 + 1.0 + 3.0 + 0.5 + 0.25 + 4.0 + 2.0);
    }
}
