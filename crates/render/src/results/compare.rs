//! `compare.json` (`osw compare`): run a against run b frame by frame, image error and, given
//! exact visibility, each run's culling error, with both runs' times.

use super::required;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Compare {
    pub a: String,
    pub b: String,
    #[serde(deserialize_with = "required")]
    pub exact: Option<String>,
    pub frames: usize,
    pub identical_frames: usize,
    /// None when every frame is identical (infinite PSNR).
    #[serde(deserialize_with = "required")]
    pub psnr_db_min: Option<f64>,
    #[serde(deserialize_with = "required")]
    pub psnr_db_median: Option<f64>,
    pub differing_fraction_mean: f64,
    pub differing_fraction_max: f64,
    pub max_channel_diff: u8,
    /// Differing pixels whose nearest node in the item buffer (`--exact-lod`'s if given, else
    /// `--exact`'s) both runs drew as the same LOD: drawing differences, not culling or LOD
    /// (osw_render::compare::unexplained_pixels); 0 for runs that draw what they cull alike.
    /// None without `--exact`, frames, or the reference's item buffers.
    #[serde(default)]
    pub unexplained_pixels: Option<u64>,
    /// Run time next to the error: each run's median frame time, and b's over a's.
    pub frame_ms_median_a: f64,
    pub frame_ms_median_b: f64,
    pub speedup_a_over_b: f64,
    /// None without exact visibility (`--exact`).
    #[serde(deserialize_with = "required")]
    pub culling_a: Option<Culling>,
    #[serde(deserialize_with = "required")]
    pub culling_b: Option<Culling>,
    /// Triangles of the clusters holding a visible triangle over visible triangles (exact.csv):
    /// the least drawn/exact ratio culling whole clusters can reach. None without `--exact` or
    /// where exact.csv does not know it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cluster_exact_triangles_ratio_mean: Option<f64>,
    /// Median ms to draw only the visible triangles (exact.csv of `--exact-lod` if given, the
    /// runs' tau, else of `--exact`): RVG's floor. None without `--exact` or where exact.csv
    /// does not know it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visible_draw_ms_median: Option<f64>,
    /// The same for the clusters holding a visible triangle: the floor of culling whole clusters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visible_cluster_draw_ms_median: Option<f64>,
    /// Each run's temporal error (osw_render::popping); None without `--popping`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub popping_a: Option<Popping>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub popping_b: Option<Popping>,
}

/// One run's popping: the fraction of pixels a frame whose colour changes by more than
/// osw_render::popping::POPPING_ABOVE when the frame's nodes are drawn with the previous
/// frame's detail, over the frames after the first.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Popping {
    pub fraction_mean: f64,
    pub fraction_max: f64,
}

/// One run's culling error against exact visibility.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Culling {
    pub false_culled_leaves_total: u64,
    pub frames_with_false_culling: u64,
    pub pvs_exact_leaves_ratio_mean: f64,
    pub pvs_exact_triangles_ratio_mean: f64,
    /// Triangles drawn (stats.csv: after cluster culling inside the PVS's nodes) over exactly
    /// visible triangles; none for a run without stats.csv.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drawn_exact_triangles_ratio_mean: Option<f64>,
    /// Against `--exact-lod`: nodes visible at the runs' tau that the PVS does not draw.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod_false_culled_total: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod_frames_with_false_culling: Option<u64>,
    /// Against `--exact-lod`: LOD nodes its item buffers show (visible at the runs' tau, at
    /// the level the node table gives) that the PVS does not draw at that level, summed over
    /// frames: 0 for a run that selects LODs as the cut at tau does.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod_not_drawn_total: Option<u64>,
}
