//! Per-frame statistics of a run on one GPU (`stats.csv`, [`crate::results::csv`]) and what
//! they sum up to in `summary.json` ([`Summary::of`], [`RenderSummary::of`]).

use crate::results::{DisplayFrame, RenderSummary, Summary};
use osw_cull::HcStats;
use osw_cull::cluster::ClusterStats;
use osw_gpu::renderer::DrawStats;
use serde::{Deserialize, Serialize};

/// One frame. Times in milliseconds.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct FrameStats {
    pub frame: u64,
    /// OR + HC + RVG: the frame's time without writing its PNG.
    pub total_ms: f64,
    /// CPU time of the process over the frame, all threads ([`cpu_ms`]).
    pub cpu_ms: f64,
    pub or_ms: f64,
    pub hc_ms: f64,
    /// HC's passes (crate::pass::hc): prev's; 0 in the other modes.
    pub hc_traversal_ms: f64,
    pub hc_second_look_ms: f64,
    pub hc_retest_ms: f64,
    pub rvg_ms: f64,
    /// Nodes (LOD/HLOD) and triangles RVG drew: the PVS.
    pub pvs_nodes: u32,
    pub triangles_drawn: u64,
    /// Nodes and triangles OR drew as occluders.
    pub or_nodes: u32,
    pub or_triangles: u64,
    /// Box tests HC issued, levels (batches), and what it culled.
    pub tests: u32,
    /// Of `tests`, those HC made again after its traversal (small boxes and additions).
    pub retests: u32,
    /// The traversal's tests by where they fall (osw_cull::HcStats): nodes of V(i-1), their
    /// siblings, and nodes inside what this frame found visible anew; prev's.
    pub tests_front: u32,
    pub tests_siblings: u32,
    pub tests_new: u32,
    pub levels: u32,
    pub frustum_culled: u32,
    pub occlusion_culled: u32,
    pub pixel_stops: u32,
    /// Boxes counted as occluded by adaptive culling, and taken untested once the culling
    /// budget was spent (ovc: Bartz 1999 eq. 1 and 2).
    pub adaptive_culled: u32,
    pub over_budget: u32,
    /// 1 when the frame was frustum culled only because occlusion culling did not pay (prev
    /// and chc, osw_cull::payoff).
    pub cull_skipped: u32,
    /// RVG's cluster tests: clusters of the PVS's nodes, and those culled by the frustum, by
    /// the back-face cone and as hidden (osw_cull::cluster); then triangles of the clusters
    /// drawn that face away or cover no pixel centre (osw_cull::triangle).
    pub clusters: u64,
    pub clusters_frustum_culled: u64,
    pub clusters_cone_culled: u64,
    pub clusters_occlusion_culled: u64,
    pub triangles_backface_culled: u64,
    pub triangles_small_culled: u64,
    /// Fragments RVG's draw rasterised (osw_gpu's `DrawStats::fragments`: what a pass costs
    /// on lavapipe), with `osw render --fragments`; empty otherwise.
    pub fragments: Option<u64>,
    /// GPU time of OR's and RVG's draws from timestamps, with `osw render --gpu-times`;
    /// empty otherwise.
    pub or_gpu_ms: Option<f64>,
    pub rvg_gpu_ms: Option<f64>,
}

impl FrameStats {
    /// OR's columns from its draws, which took `or_ms`.
    pub fn take_or(&mut self, or: &DrawStats, or_ms: f64) {
        (self.or_ms, self.or_nodes, self.or_triangles, self.or_gpu_ms) = (or_ms, or.nodes, or.triangles, or.gpu_ms());
    }

    /// HC's counts.
    pub fn take_hc(&mut self, hc: &HcStats) {
        (self.tests, self.retests, self.levels, self.frustum_culled, self.occlusion_culled, self.pixel_stops) =
            (hc.tests, hc.retests, hc.levels, hc.frustum_culled, hc.occlusion_culled, hc.pixel_stops);
        (self.tests_front, self.tests_siblings, self.tests_new) = (hc.tests_front, hc.tests_siblings, hc.tests_new);
        (self.adaptive_culled, self.over_budget) = (hc.adaptive_culled, hc.over_budget);
    }

    /// RVG's counts from its draw: nodes, triangles, clusters, and fragments where `fragments`
    /// were counted.
    pub fn take_rvg(&mut self, drawn: &DrawStats, fragments: bool) {
        (self.pvs_nodes, self.triangles_drawn) = (drawn.nodes, drawn.triangles);
        self.fragments = fragments.then_some(drawn.fragments);
        [
            self.clusters,
            self.clusters_frustum_culled,
            self.clusters_cone_culled,
            self.clusters_occlusion_culled,
            self.triangles_backface_culled,
            self.triangles_small_culled,
        ] = cluster_columns(&drawn.clusters);
    }
}

/// The six cluster columns that `stats.csv` and the display's rows share, in their order
/// (clusters, frustum-, cone- and occlusion-culled; triangles back-face and small culled),
/// from RVG's draw.
pub fn cluster_columns(c: &ClusterStats) -> [u64; 6] {
    [c.clusters, c.frustum_culled, c.cone_culled, c.occlusion_culled, c.backface_culled, c.small_culled]
}

/// The display's frame as one GPU's: the keys every summary has ([`Summary::of`]).
impl From<&DisplayFrame> for FrameStats {
    fn from(r: &DisplayFrame) -> FrameStats {
        FrameStats {
            frame: r.frame,
            total_ms: r.frame_ms,
            hc_ms: r.hc_ms,
            hc_traversal_ms: r.hc_traversal_ms,
            hc_second_look_ms: r.hc_second_look_ms,
            hc_retest_ms: r.hc_retest_ms,
            rvg_ms: r.rvg_ms,
            rvg_gpu_ms: r.rvg_gpu_ms,
            pvs_nodes: r.pvs_nodes,
            triangles_drawn: r.triangles_drawn,
            tests: r.tests,
            cull_skipped: r.cull_skipped,
            clusters: r.clusters,
            clusters_frustum_culled: r.clusters_frustum_culled,
            clusters_cone_culled: r.clusters_cone_culled,
            clusters_occlusion_culled: r.clusters_occlusion_culled,
            triangles_backface_culled: r.triangles_backface_culled,
            triangles_small_culled: r.triangles_small_culled,
            ..FrameStats::default()
        }
    }
}

/// Resident memory of this process in bytes (Linux /proc; 0 elsewhere).
pub fn resident_bytes() -> u64 {
    statm().map_or(0, |(resident, _)| resident)
}

/// Of [`resident_bytes`], the anonymous memory: what is not a file's pages (the mapped scene).
pub fn anonymous_bytes() -> u64 {
    statm().map_or(0, |(resident, shared)| resident.saturating_sub(shared))
}

/// Resident and file-backed resident bytes of this process (0 where unsupported).
fn statm() -> Option<(u64, u64)> {
    let s = std::fs::read_to_string("/proc/self/statm").ok()?;
    let mut pages = s.split_whitespace().skip(1).map(|f| f.parse::<u64>().map(|p| p * 4096));
    Some((pages.next()?.ok()?, pages.next()?.ok()?))
}

/// CPU time this process has used so far, all threads, in ms: on lavapipe the GPU's work is
/// CPU work too, so this is what a run takes from the host's cores (0 where unsupported).
pub fn cpu_ms() -> f64 {
    let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes one timespec through the pointer it is given.
    match unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) } {
        0 => t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 * 1e-6,
        _ => 0.0,
    }
}

/// Peak resident memory of this process so far in KiB (Linux /proc VmHWM; 0 elsewhere).
pub fn peak_resident_kb() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find_map(|l| l.strip_prefix("VmHWM:")?.trim().strip_suffix("kB")?.trim().parse().ok()))
        .unwrap_or(0)
}

/// The `q` quantile (0..=1) of `v` by nearest rank; 0 for no values.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((s.len() - 1) as f64 * q).round() as usize]
}

/// The mean of `v`; 0 for no values.
pub fn mean(v: impl IntoIterator<Item = f64>) -> f64 {
    let (sum, n) = v.into_iter().fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { 0.0 } else { sum / n as f64 }
}

/// The median of the GPU times taken (a frame that drew nothing has none); none when none was.
pub fn gpu_median(ms: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let v: Vec<f64> = ms.flatten().collect();
    (!v.is_empty()).then(|| quantile(&v, 0.5))
}

/// Culled clusters over all clusters tested, over every frame.
fn share(frames: &[FrameStats], culled: fn(&FrameStats) -> u64) -> f64 {
    let all: u64 = frames.iter().map(|f| f.clusters).sum();
    frames.iter().map(culled).sum::<u64>() as f64 / all.max(1) as f64
}

impl Summary {
    /// The keys every run has, from `frames`; the caller fills the run's identity.
    pub fn of(frames: &[FrameStats]) -> Summary {
        let col = |f: fn(&FrameStats) -> f64| frames.iter().map(f).collect::<Vec<f64>>();
        let total = col(|f| f.total_ms);
        Summary {
            frames: frames.len() as u64,
            frame_ms_median: quantile(&total, 0.5),
            frame_ms_p95: quantile(&total, 0.95),
            triangles_drawn_mean: mean(frames.iter().map(|f| f.triangles_drawn as f64)),
            pvs_nodes_mean: mean(frames.iter().map(|f| f.pvs_nodes as f64)),
            tests_mean: mean(frames.iter().map(|f| f.tests as f64)),
            cull_skipped_frames: frames.iter().map(|f| f.cull_skipped as u64).sum(),
            clusters_mean: mean(frames.iter().map(|f| f.clusters as f64)),
            clusters_frustum_culled_fraction: share(frames, |f| f.clusters_frustum_culled),
            clusters_cone_culled_fraction: share(frames, |f| f.clusters_cone_culled),
            clusters_occlusion_culled_fraction: share(frames, |f| f.clusters_occlusion_culled),
            triangles_backface_culled_mean: mean(frames.iter().map(|f| f.triangles_backface_culled as f64)),
            triangles_small_culled_mean: mean(frames.iter().map(|f| f.triangles_small_culled as f64)),
            hc_ms_median: quantile(&col(|f| f.hc_ms), 0.5),
            hc_traversal_ms_median: quantile(&col(|f| f.hc_traversal_ms), 0.5),
            hc_second_look_ms_median: quantile(&col(|f| f.hc_second_look_ms), 0.5),
            hc_retest_ms_median: quantile(&col(|f| f.hc_retest_ms), 0.5),
            rvg_ms_median: quantile(&col(|f| f.rvg_ms), 0.5),
            ..Summary::default()
        }
    }
}

impl RenderSummary {
    /// The keys of one GPU's run, from `frames`; the caller fills the run's knobs and memory.
    pub fn of(frames: &[FrameStats]) -> RenderSummary {
        let rates: Vec<f64> = frames.iter().filter(|f| f.tests > 0 && f.hc_ms > 0.0).map(|f| f.tests as f64 / (f.hc_ms / 1e3)).collect();
        RenderSummary {
            or_ms_median: quantile(&frames.iter().map(|f| f.or_ms).collect::<Vec<f64>>(), 0.5),
            adaptive_culled_mean: mean(frames.iter().map(|f| f.adaptive_culled as f64)),
            over_budget_mean: mean(frames.iter().map(|f| f.over_budget as f64)),
            hc_tests_per_second_median: quantile(&rates, 0.5),
            retests_mean: mean(frames.iter().map(|f| f.retests as f64)),
            tests_front_mean: mean(frames.iter().map(|f| f.tests_front as f64)),
            tests_siblings_mean: mean(frames.iter().map(|f| f.tests_siblings as f64)),
            tests_new_mean: mean(frames.iter().map(|f| f.tests_new as f64)),
            fragments_mean: frames
                .iter()
                .map(|f| f.fragments.map(|n| n as f64))
                .sum::<Option<f64>>()
                .map(|sum| sum / frames.len().max(1) as f64),
            or_gpu_ms_median: gpu_median(frames.iter().map(|f| f.or_gpu_ms)),
            rvg_gpu_ms_median: gpu_median(frames.iter().map(|f| f.rvg_gpu_ms)),
            ..RenderSummary::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_by_nearest_rank() {
        let v = [5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(quantile(&v, 0.5), 3.0);
        assert_eq!(quantile(&v, 0.95), 5.0);
        assert_eq!(quantile(&[], 0.5), 0.0);
    }

    #[test]
    fn csv_has_a_column_per_field_in_order_and_reads_back() {
        let csv = crate::results::csv::to_string(&[FrameStats { frame: 3, tests: 7, rvg_ms: 1.5, ..Default::default() }]);
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(header[0], "frame");
        let row: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(row.len(), header.len());
        assert_eq!(row[header.iter().position(|h| *h == "tests").unwrap()], "7");
        let back: Vec<FrameStats> = crate::results::csv::parse(&csv).unwrap();
        assert_eq!((back[0].frame, back[0].tests, back[0].rvg_ms), (3, 7, 1.5));
    }
}
