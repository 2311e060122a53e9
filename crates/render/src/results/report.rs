//! `report.json` (`osw report`): every run of a report, its time next to its error.

use super::required;
use crate::mode::Mode;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Report {
    pub scene: String,
    pub path: String,
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    /// Triangles of the scene at full detail.
    pub scene_triangles: u64,
    pub exact_leaves_mean: f64,
    pub exact_triangles_mean: f64,
    pub runs: Vec<Entry>,
}

/// One run of the report: a mode at a tau, its run time and its error.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Entry {
    pub mode: Mode,
    pub tau: f64,
    /// The adaptive-culling threshold (0: conservative).
    pub adaptive: f64,
    pub frame_ms_median: f64,
    pub frame_ms_p95: f64,
    pub or_ms_median: f64,
    pub hc_ms_median: f64,
    pub rvg_ms_median: f64,
    /// Frame time of `vfc` at the same tau over this run's median.
    #[serde(deserialize_with = "required")]
    pub speedup_vs_vfc: Option<f64>,
    pub triangles_drawn_mean: f64,
    pub pvs_nodes_mean: f64,
    pub tests_mean: f64,
    /// RVG's clusters a frame and the shares culled inside the PVS's nodes (osw_cull::cluster).
    pub clusters_mean: f64,
    pub clusters_frustum_culled_fraction: f64,
    pub clusters_cone_culled_fraction: f64,
    pub clusters_occlusion_culled_fraction: f64,
    /// Triangles of the clusters drawn that face away or cover no pixel centre, a frame
    /// (osw_cull::triangle).
    pub triangles_backface_culled_mean: f64,
    pub triangles_small_culled_mean: f64,
    pub pvs_exact_leaves: f64,
    pub pvs_exact_triangles: f64,
    /// Triangles drawn after cluster culling over exactly visible triangles.
    pub drawn_exact_triangles: f64,
    /// Leaves visible at full detail that the method does not draw (at tau > 0 also those
    /// that coarse LODs hide: LOD error).
    pub false_culled_leaves_total: u64,
    pub frames_with_false_culling: u64,
    /// Nodes visible at the run's tau that the method does not draw: culling error alone.
    pub false_culled_at_tau_total: u64,
    /// Image error against `vfc` at tau 0 (full detail, nothing occlusion-culled).
    #[serde(deserialize_with = "required")]
    pub psnr_db_median: Option<f64>,
    #[serde(deserialize_with = "required")]
    pub psnr_db_min: Option<f64>,
    pub identical_frames: u64,
    pub differing_fraction_mean: f64,
    pub differing_fraction_max: f64,
    /// Temporal error: the pixels a frame that pop (osw_render::popping), mean.
    pub popping_fraction_mean: f64,
    /// The switch's traffic and latency (its display's summary); none for the other modes.
    #[serde(deserialize_with = "required")]
    pub traffic: Option<Traffic>,
    /// Why the run failed, when it did; its other fields are then zero.
    #[serde(deserialize_with = "required")]
    pub error: Option<String>,
}

/// What the switch sends (occlusion switch sec. 3.5 and fig. 3) and how late frames are shown.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Traffic {
    pub ids_sent_mean: f64,
    pub ids_full_mean: f64,
    pub incremental_saved_fraction: f64,
    /// All bytes HC sends RVG a frame: camera, deltas, end of frame.
    pub bytes_per_frame_mean: f64,
    /// Bytes of the id-carrying messages per id sent.
    pub id_bytes_per_id: f64,
    pub latency_ms_median: f64,
    pub latency_ms_p95: f64,
}

impl From<&super::SwitchSummary> for Traffic {
    fn from(s: &super::SwitchSummary) -> Traffic {
        Traffic {
            ids_sent_mean: s.ids_sent_mean,
            ids_full_mean: s.ids_full_mean,
            incremental_saved_fraction: s.incremental_saved_fraction,
            bytes_per_frame_mean: s.bytes_per_frame_mean,
            id_bytes_per_id: s.id_bytes_per_id,
            latency_ms_median: s.latency_ms_median,
            latency_ms_p95: s.latency_ms_p95,
        }
    }
}

impl Entry {
    /// The run as the tables name it: the mode, and its adaptive threshold when it has one.
    pub fn label(&self) -> String {
        if self.adaptive == 0.0 { self.mode.name().to_owned() } else { format!("{} (adaptive {})", self.mode.name(), self.adaptive) }
    }
}
