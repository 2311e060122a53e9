//! `summary.json`: the keys every run has, then those of how it ran (one GPU, or the switch).

use super::{ResultsError, required};
use crate::mode::Mode;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A run's summary. Times in milliseconds; means and medians over the run's frames.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Summary {
    pub mode: Mode,
    pub tau: f64,
    pub frames: u64,
    /// One GPU: OR + HC + RVG of a frame, without writing its PNG. The switch: the interval
    /// between frames shown, from the second on.
    pub frame_ms_median: f64,
    pub frame_ms_p95: f64,
    pub triangles_drawn_mean: f64,
    pub pvs_nodes_mean: f64,
    pub tests_mean: f64,
    /// Frames frustum culled only because occlusion culling culled fewer triangles than it
    /// cost (cost-adaptive culling, osw_cull::payoff; `--always-cull` turns it off).
    #[serde(default)]
    pub cull_skipped_frames: u64,
    /// RVG's clusters a frame, and the share culled by the frustum, the cone and as hidden.
    pub clusters_mean: f64,
    pub clusters_frustum_culled_fraction: f64,
    pub clusters_cone_culled_fraction: f64,
    pub clusters_occlusion_culled_fraction: f64,
    /// Triangles of the clusters drawn that RVG's triangle tests dropped, a frame.
    pub triangles_backface_culled_mean: f64,
    pub triangles_small_culled_mean: f64,
    pub hc_ms_median: f64,
    /// HC's passes (osw_render::pass::hc): prev and the switch; 0 in the other modes.
    #[serde(default)]
    pub hc_traversal_ms_median: f64,
    #[serde(default)]
    pub hc_second_look_ms_median: f64,
    #[serde(default)]
    pub hc_retest_ms_median: f64,
    pub rvg_ms_median: f64,
    pub scene: String,
    pub scene_hash: String,
    pub path: String,
    pub width: u32,
    pub height: u32,
    /// How textured surfaces were coloured: `sampled`, `means` (each texture's mean colour,
    /// `--no-textures`), or `none` where the scene has no textures.
    #[serde(default)]
    pub textures: String,
    /// The keys of how it ran, written after these.
    #[serde(skip)]
    pub of: Details,
}

/// [`Summary::textures`] of a run on `scene` that samples textures where `sampled`.
pub fn textures_key(scene: &osw_scene::SceneFile, sampled: bool) -> String {
    match (scene.textures().is_empty(), sampled) {
        (true, _) => "none",
        (false, true) => "sampled",
        (false, false) => "means",
    }
    .to_owned()
}

#[derive(Clone, Debug)]
pub enum Details {
    Render(RenderSummary),
    Switch(SwitchSummary),
}

impl Default for Details {
    fn default() -> Details {
        Details::Render(RenderSummary::default())
    }
}

/// `osw render`: one mode on one GPU.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RenderSummary {
    pub or_ms_median: f64,
    /// The HC box test `prev` used (`--hc`).
    pub hc_test: String,
    /// ovc's knobs (Bartz 1999): eq. 1's threshold (0: off), eq. 2's factor (0: no budget) and
    /// the lines sampled; boxes a frame culled adaptively and taken untested over budget.
    pub adaptive: f64,
    pub budget: f64,
    pub sampling: u32,
    pub adaptive_culled_mean: f64,
    pub over_budget_mean: f64,
    /// Box tests per second of HC time (tests / hc_ms), median over frames with tests.
    pub hc_tests_per_second_median: f64,
    pub adapter: String,
    pub uploads: u64,
    pub upload_bytes: u64,
    /// The vertex bytes of nodes drawn from a mesh already on the GPU for another of its uses
    /// (`ResidencyStats::shared_bytes`): what storing each use on its own would have added.
    #[serde(default)]
    pub upload_shared_bytes: u64,
    pub evictions: u64,
    /// What the run left out: geometry blocks (LOD/HLOD nodes) never drawn, so never read
    /// from the file nor uploaded, and their share of the scene's geometry.
    pub blocks_never_loaded: u64,
    pub blocks_total: u64,
    pub geometry_never_loaded_fraction: f64,
    /// Peak resident memory of the process at the end of the run.
    pub peak_rss_kb: u64,
    /// RVG's fragments a frame, when counted (`osw render --fragments`); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fragments_mean: Option<f64>,
    /// OR's and RVG's GPU time a frame from timestamps (`osw render --gpu-times`); absent
    /// otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub or_gpu_ms_median: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rvg_gpu_ms_median: Option<f64>,
    /// Of `tests_mean`, the retests after the traversal, and the traversal's tests of V(i-1)'s
    /// nodes, of their siblings and of what came into view (prev; 0 in the other modes).
    #[serde(default)]
    pub retests_mean: f64,
    #[serde(default)]
    pub tests_front_mean: f64,
    #[serde(default)]
    pub tests_siblings_mean: f64,
    #[serde(default)]
    pub tests_new_mean: f64,
}

/// `osw run`: the switch, as its display saw it, and the nodes' stage times.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct SwitchSummary {
    pub bytes_per_frame_mean: f64,
    pub ids_sent_mean: f64,
    pub ids_full_mean: f64,
    pub incremental_saved_fraction: f64,
    pub bytes_per_id: f64,
    /// Bytes of the id-carrying messages per id sent: occlusion switch sec. 3.5's 4 bytes an id plus
    /// packet headers, without the camera and end of frame that every frame sends anyway.
    pub id_bytes_per_id: f64,
    /// Bytes a frame of HC's cluster masks to RVG (osw_wire::messages::ClusterMask), in
    /// `bytes_per_frame_mean`: the paper's wire has none.
    #[serde(default)]
    pub mask_bytes_per_frame_mean: f64,
    /// Ids per delta batch, the paper's b.
    pub batch: usize,
    pub latency_ms_median: f64,
    pub latency_ms_p95: f64,
    pub latency_ms_max: f64,
    /// The same in frames (of the median frame time), and the floor
    /// ([`crate::results::latency_floor_ms`]) in both.
    #[serde(default)]
    pub latency_frames_median: f64,
    #[serde(default)]
    pub latency_frames_p95: f64,
    #[serde(default)]
    pub latency_frames_max: f64,
    #[serde(default)]
    pub latency_floor_ms: f64,
    #[serde(default)]
    pub latency_floor_frames: f64,
    pub camera_link_ms_median: f64,
    pub eof_link_ms_median: f64,
    pub peer_link_ms_median: f64,
    /// Failover (docs/switch.md): node connections lost and made again, frames made by one node
    /// alone, and the first and last of them.
    pub node_losses: u32,
    pub node_rejoins: u32,
    /// Peers refused for a wrong proof of the cluster token: the display's, and the nodes'
    /// merged in by `osw run`.
    #[serde(default)]
    pub auth_refusals: u64,
    /// Geometry the display dropped from the GPU over its residency budget.
    #[serde(default)]
    pub evictions: u64,
    /// Bytes the display and the nodes wrote to their sockets a frame (TLS records as sent, no
    /// TCP or IP headers; the nodes' merged in by `osw run`): what `bytes_per_frame_mean` costs
    /// on the wire, with the cameras, heartbeats and handshakes.
    #[serde(default)]
    pub wire_bytes_per_frame_mean: f64,
    pub degraded_frames: u64,
    #[serde(deserialize_with = "required")]
    pub degraded_first_frame: Option<u64>,
    #[serde(deserialize_with = "required")]
    pub degraded_last_frame: Option<u64>,
    /// Node a's and b's clock minus the display's, and the round trip of the probe used.
    pub clock_offset_a_us: f64,
    pub clock_offset_b_us: f64,
    pub clock_rtt_a_us: f64,
    pub clock_rtt_b_us: f64,
    /// RVG's GPU time a frame from timestamps (`osw run --gpu-times`), and OR's over both
    /// nodes' OR frames (merged in by `osw run`); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rvg_gpu_ms_median: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub or_gpu_ms_median: Option<f64>,
    /// Each node's median HC and OR frame time from its `node-*.csv`, merged in by `osw run`;
    /// null when the node wrote none (it was killed, or the display was started alone).
    #[serde(deserialize_with = "required")]
    pub node_a_hc_ms_median: Option<f64>,
    #[serde(deserialize_with = "required")]
    pub node_a_or_ms_median: Option<f64>,
    #[serde(deserialize_with = "required")]
    pub node_b_hc_ms_median: Option<f64>,
    #[serde(deserialize_with = "required")]
    pub node_b_or_ms_median: Option<f64>,
}

impl Summary {
    pub fn read(dir: &Path) -> Result<Summary, ResultsError> {
        let path = dir.join("summary.json");
        let v: serde_json::Value = super::read_json(&path)?;
        let mut s: Summary = serde_json::from_value(v.clone()).map_err(|e| ResultsError::new(&path, e))?;
        s.of = match s.mode {
            Mode::Switch => Details::Switch(serde_json::from_value(v).map_err(|e| ResultsError::new(&path, e))?),
            _ => Details::Render(serde_json::from_value(v).map_err(|e| ResultsError::new(&path, e))?),
        };
        Ok(s)
    }

    pub fn write(&self, dir: &Path) -> Result<(), ResultsError> {
        let path = dir.join("summary.json");
        if (self.mode == Mode::Switch) != matches!(self.of, Details::Switch(_)) {
            return Err(ResultsError::new(&path, format!("mode {} with the keys of another kind of run", self.mode)));
        }
        let mut v = serde_json::to_value(self).map_err(|e| ResultsError::new(&path, e))?;
        let details = match &self.of {
            Details::Render(r) => serde_json::to_value(r),
            Details::Switch(s) => serde_json::to_value(s),
        };
        if let (Some(o), Ok(serde_json::Value::Object(d))) = (v.as_object_mut(), details) {
            o.extend(d);
        }
        super::write_json(&path, &v)
    }

    pub fn render(&self) -> Option<&RenderSummary> {
        match &self.of {
            Details::Render(r) => Some(r),
            Details::Switch(_) => None,
        }
    }

    pub fn switch(&self) -> Option<&SwitchSummary> {
        match &self.of {
            Details::Switch(s) => Some(s),
            Details::Render(_) => None,
        }
    }

    /// OR's median frame time: the switch's is the mean of the nodes' medians it has.
    pub fn or_ms_median(&self) -> Option<f64> {
        match &self.of {
            Details::Render(r) => Some(r.or_ms_median),
            Details::Switch(s) => {
                let m: Vec<f64> = [s.node_a_or_ms_median, s.node_b_or_ms_median].into_iter().flatten().collect();
                (!m.is_empty()).then(|| m.iter().sum::<f64>() / m.len() as f64)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn written(s: &Summary) -> (tempfile::TempDir, serde_json::Value) {
        let d = tempfile::tempdir().unwrap();
        s.write(d.path()).unwrap();
        let v = serde_json::from_str(&std::fs::read_to_string(d.path().join("summary.json")).unwrap()).unwrap();
        (d, v)
    }

    fn switch(s: SwitchSummary) -> Summary {
        Summary { mode: Mode::Switch, of: Details::Switch(s), ..Default::default() }
    }

    #[test]
    fn a_summary_reads_back_as_written() {
        let render = Summary {
            mode: Mode::Prev,
            frames: 3,
            frame_ms_median: 12.5,
            of: Details::Render(RenderSummary { uploads: 7, ..Default::default() }),
            ..Default::default()
        };
        let switch = switch(SwitchSummary { batch: 64, node_b_or_ms_median: Some(4.0), ..Default::default() });
        for s in [render, switch] {
            let (d, v) = written(&s);
            assert_eq!(v["mode"], s.mode.name());
            let back = Summary::read(d.path()).unwrap();
            assert_eq!((back.frames, back.frame_ms_median), (s.frames, s.frame_ms_median));
            assert_eq!(back.render().map(|r| r.uploads), s.render().map(|r| r.uploads));
            assert_eq!(back.switch().map(|r| (r.batch, r.node_b_or_ms_median)), s.switch().map(|r| (r.batch, r.node_b_or_ms_median)));
        }
    }

    /// A renamed key, of the common part, of one mode's or a nullable one, is an error
    /// naming it, not a default.
    #[test]
    fn a_renamed_key_is_an_error_naming_it() {
        let (render, switch) = (Summary::default(), switch(SwitchSummary::default()));
        let cases = [
            (&render, "frame_ms_median"),
            (&render, "peak_rss_kb"),
            (&switch, "latency_ms_median"),
            (&switch, "node_a_or_ms_median"),
            (&switch, "degraded_first_frame"),
        ];
        for (s, key) in cases {
            let (d, v) = written(s);
            let text = serde_json::to_string_pretty(&v).unwrap().replace(&format!("\"{key}\""), &format!("\"{key}_renamed\""));
            std::fs::write(d.path().join("summary.json"), text).unwrap();
            let e = Summary::read(d.path()).unwrap_err().to_string();
            assert!(e.contains(&format!("missing field `{key}`")) && e.contains("summary.json"), "{key}: {e}");
        }
    }

    #[test]
    fn an_unknown_mode_is_an_error_naming_it() {
        let (d, v) = written(&Summary::default());
        std::fs::write(d.path().join("summary.json"), v.to_string().replace("\"vfc\"", "\"gigawalk\"")).unwrap();
        let e = Summary::read(d.path()).unwrap_err().to_string();
        assert!(e.contains("gigawalk"), "{e}");
    }

    #[test]
    fn the_switch_or_time_is_the_mean_of_the_nodes_it_has() {
        let s = |a, b| switch(SwitchSummary { node_a_or_ms_median: a, node_b_or_ms_median: b, ..Default::default() });
        assert_eq!(s(Some(2.0), Some(4.0)).or_ms_median(), Some(3.0));
        assert_eq!(s(None, Some(4.0)).or_ms_median(), Some(4.0));
        assert_eq!(s(None, None).or_ms_median(), None);
    }
}
