//! A switch node's frames (`node-a.csv`, `node-b.csv`), written by `osw-node --stats` and read
//! by `osw run` (stage times), `osw bandwidth` (bytes per link) and `osw scale` (memory).

use serde::{Deserialize, Serialize};

/// What a node does in a frame (occlusion switch alg. 4.2; and failover, docs/switch.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Duty {
    Hc,
    Or,
    /// OR and HC in turn, alone: the first frame, the peer gone, or handing it a keyframe.
    #[default]
    Solo,
}

/// One frame of a node.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct NodeFrame {
    pub frame: u64,
    #[serde(rename = "role")]
    pub duty: Duty,
    pub ms: f64,
    /// Of `ms`, OR's draws (as OR, or alone before HC), and HC's passes
    /// (osw_render::pass::hc); waits and sending are the rest.
    pub or_ms: f64,
    pub hc_traversal_ms: f64,
    pub hc_second_look_ms: f64,
    pub hc_retest_ms: f64,
    /// OR's draws on the GPU, from timestamps (`osw-node --gpu-times`); empty otherwise.
    pub or_gpu_ms: Option<f64>,
    pub nodes_drawn: u32,
    pub tests: u32,
    /// Of `tests`, those HC made again after its traversal (small boxes and additions).
    pub retests: u32,
    /// CPU time of this process since its previous frame, all threads
    /// (osw_render::stats::cpu_ms).
    pub cpu_ms: f64,
    /// 1 when HC frustum culled only (cost-adaptive culling).
    pub cull_skipped: u32,
    pub ids_sent: u64,
    /// Delta batches and bytes (frames as encoded) this node sent as HC, per link.
    pub batches: u32,
    pub bytes_to_peer: u64,
    pub bytes_to_display: u64,
    /// Resident memory at the end of the frame (a soak shows it flat).
    pub rss_kb: u64,
    /// Peers refused so far for a wrong proof of the cluster token (osw_wire::auth).
    #[serde(default)]
    pub auth_refusals: u64,
    /// Bytes this node has written to its sockets so far (TLS records as sent).
    #[serde(default)]
    pub wire_bytes_sent: u64,
}

/// The median frame time of `frames` with `duty`, if there are any.
pub fn duty_median_ms(frames: &[NodeFrame], duty: Duty) -> Option<f64> {
    let ms: Vec<f64> = frames.iter().filter(|f| f.duty == duty).map(|f| f.ms).collect();
    (!ms.is_empty()).then(|| crate::stats::quantile(&ms, 0.5))
}
