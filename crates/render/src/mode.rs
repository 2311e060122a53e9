//! Culling modes and their per-frame algorithms. Each frame reads as a list of passes, each
//! timed: OR (occluders), HC (the cull), RVG (drawing the visible set).
//!
//! - `vfc`: frustum culling only, LODs at tau.
//! - `sw`: hierarchical stop-and-wait tests, front to back (CHC sec. 3.3): `ovc` without
//!   its knobs.
//! - `ovc`: Bartz 1999's depth-ordered interleaved culling, with adaptive culling (eq. 1), the
//!   cost-adaptive budget (eq. 2) and interleaved sampling of the box tests (sec. 3.3).
//! - `chc`: coherent hierarchical culling (CHC fig. 2), batched for wgpu's readback.
//! - `hzb`: Peng 2014 (sec. 5.2-5.3): occluders picked by eq. 3 drawn at full
//!   detail, depth read back, a Z pyramid built and boxes tested on the CPU.
//! - `prev`: the occlusion switch's algorithm on one GPU (Yoon 2003 fig. 5, occlusion switch alg.
//!   4.2), exactly as the two switch nodes run it: the OR of frame i happens while HC of frame
//!   i-1 is still streaming, so it draws the front of V(i-2) updated for camera i (sec. 4.6),
//!   then the additions of frame i-1 as they arrive, into the depth buffer; HC tests the
//!   hierarchy against it (alg. 4.1); RVG draws V(i), on one GPU over the depth OR and HC
//!   left (Yoon 2003 sec. 5.4).
//! - `switch`: the same on two nodes and a display (`osw run`, crates/node); not a mode of
//!   [`ModeState`], named here so that runs, reports and results share one enum.

use crate::pass::{self, HcOptions, HcTest};
use crate::stats::FrameStats;
use osw_cull::chc::ChcState;
use osw_cull::cluster::VisibleClusters;
use osw_cull::delta::diff;
use osw_cull::hzb::{ACTIVE_OCCLUDERS, HzbTester, Pyramid, Read, select_occluders};
use osw_cull::ovc::{OvcOptions, ovc};
use osw_cull::payoff::Alternating;
use osw_cull::view::Cut;
use osw_cull::{HcStats, View, frustum_cull, hardware_cull};
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{BoxTest, DrawStats, RenderError, Renderer, Sampling};
use osw_gpu::testers::{GpuTester, InterleavedTester};
use osw_scene::{NodeId, SceneFile};
use std::time::Instant;

/// Every method osw runs, by the name runs, reports and results use. All but the switch run
/// on one GPU ([`ModeState`], `osw render`); the switch runs on two nodes and a display (`osw
/// run`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    #[default]
    Vfc,
    Sw,
    Chc,
    Hzb,
    Prev,
    Ovc,
    Switch,
}

impl Mode {
    pub const ALL: [Mode; 7] = [Mode::Vfc, Mode::Sw, Mode::Chc, Mode::Hzb, Mode::Prev, Mode::Ovc, Mode::Switch];

    pub fn name(self) -> &'static str {
        match self {
            Mode::Vfc => "vfc",
            Mode::Sw => "sw",
            Mode::Chc => "chc",
            Mode::Hzb => "hzb",
            Mode::Prev => "prev",
            Mode::Ovc => "ovc",
            Mode::Switch => "switch",
        }
    }

    /// Whether the mode runs on one GPU (`osw render`), or why not.
    pub fn on_one_gpu(self) -> Result<(), ModeError> {
        match self {
            Mode::Switch => Err(ModeError::Switch),
            _ => Ok(()),
        }
    }

    /// The modes with adaptive culling (Bartz 1999 eq. 1): ovc in its traversal, prev and the
    /// switch in HC's exact tests.
    pub fn adaptive(self) -> bool {
        matches!(self, Mode::Ovc | Mode::Prev | Mode::Switch)
    }
}

/// Why a mode does not run on one GPU ([`Mode::on_one_gpu`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ModeError {
    #[error("--mode switch: the switch runs on two nodes and a display, `osw run` (its algorithm on one GPU is prev)")]
    Switch,
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Mode, String> {
        Mode::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Mode::ALL.iter().map(|m| m.name()).collect();
            format!("unknown mode {s:?}: expected one of {}", names.join(", "))
        })
    }
}

/// A mode's state across frames.
pub struct ModeState {
    pub mode: Mode,
    pub tau: f64,
    /// How `prev` tests boxes: `Hybrid`, `Pyramid`, `Exact` (counting pixels when tau > 0) or
    /// `Queries`.
    pub hc: HcTest,
    /// V(i-1): last frame's visible set (LOD ids, sorted), and V(i-2).
    visible: Vec<NodeId>,
    older: Vec<NodeId>,
    added: Vec<NodeId>,
    removed: Vec<NodeId>,
    occluders: Vec<NodeId>,
    /// The nodes HC found visible (osw_cull::hardware_cull_seen), one set per parity of the
    /// frame: the switch's two HC nodes each keep their own, from two frames back, and prev
    /// takes the same sets so that its visible sets are the switch's.
    seen: [Vec<NodeId>; 2],
    chc: Option<ChcState>,
    /// Paper 003's knobs (ovc), the last frame's render time (eq. 2's T_render) and the frames
    /// so far (which pixel lines sampled tests read).
    pub ovc: OvcOptions,
    /// Cost-adaptive culling of prev and chc (osw_cull::payoff): frames whose occlusion
    /// culling does not pay are frustum culled only. None culls every frame (the papers').
    pub payoff: Option<Alternating>,
    last_render_ms: Option<f64>,
    frames: u32,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

impl ModeState {
    /// A mode's state, or why it cannot run on one GPU (the switch).
    pub fn new(mode: Mode, tau: f64, hc: HcTest) -> Result<ModeState, ModeError> {
        mode.on_one_gpu()?;
        Ok(ModeState {
            mode,
            tau,
            hc,
            visible: Vec::new(),
            older: Vec::new(),
            added: Vec::new(),
            removed: Vec::new(),
            occluders: Vec::new(),
            seen: [Vec::new(), Vec::new()],
            chc: None,
            ovc: OvcOptions::default(),
            payoff: None,
            last_render_ms: None,
            frames: 0,
        })
    }

    /// The visible set of the last frame rendered (LOD ids, sorted).
    pub fn visible(&self) -> &[NodeId] {
        &self.visible
    }

    /// Renders one frame for `view` into the renderer's colour target: the mode's culling,
    /// each pass timed, then RVG.
    pub fn frame(&mut self, r: &mut Renderer, scene: &SceneFile, view: &View) -> Result<FrameStats, RenderError> {
        r.begin_frame();
        let mut s = FrameStats::default();
        let mut pvs = Vec::new();
        // Whether this frame's occlusion culling is expected to pay (prev and chc; see
        // osw_cull::payoff), from the counts of the last frame judged.
        let frame = self.frames as u64;
        let cull = !matches!(self.mode, Mode::Prev | Mode::Chc) || self.payoff.as_mut().is_none_or(|p| p.of(frame).cull());
        s.cull_skipped = u32::from(!cull);
        // A frame that skips occlusion culling is frustum culled.
        let (hc, rvg) = match if cull { self.mode } else { Mode::Vfc } {
            Mode::Vfc => (self.vfc(scene, view, &mut s, &mut pvs), Rvg::Plain),
            Mode::Sw | Mode::Chc | Mode::Ovc => (self.ordered(r, scene, view, &mut s, &mut pvs)?, Rvg::Plain),
            Mode::Hzb => (self.hzb(r, scene, view, &mut s, &mut pvs)?, Rvg::Plain),
            // The switch's algorithm on one GPU (`new` refuses the switch itself).
            Mode::Prev | Mode::Switch => self.prev(r, scene, view, &mut s, &mut pvs)?,
        };
        // One draw order for every mode: sorted ids, so equal sets give equal pixels even
        // where surfaces tie in depth.
        pvs.sort_unstable();
        pvs.dedup();
        // A frame without occluders (prev's first, or one after a view of nothing) culls
        // nothing, whatever culling would save: it is not judged.
        let judged = cull && (self.mode == Mode::Chc || (self.mode == Mode::Prev && !self.visible.is_empty()));
        if let Some(p) = self.payoff.as_mut().filter(|_| judged) {
            p.of(frame).judge_hc(scene.nodes(), &hc, &pvs);
        }
        let t = Instant::now();
        let drawn = match rvg {
            Rvg::Plain => r.draw(scene, view, &pvs, Pass::Color, Load::Clear)?,
            Rvg::Switch { notes, pass } => pass::rvg(r, scene, view, &pvs, notes.as_ref(), pass)?,
        };
        (s.rvg_ms, s.rvg_gpu_ms) = (ms(t), drawn.gpu_ms());
        s.total_ms = s.or_ms + s.hc_ms + s.rvg_ms;
        s.take_hc(&hc);
        s.take_rvg(&drawn, r.counts_fragments());
        (self.last_render_ms, self.frames) = (Some(s.rvg_ms), self.frames + 1);
        self.older = std::mem::replace(&mut self.visible, pvs);
        Ok(s)
    }

    /// vfc: frustum culling only.
    fn vfc(&self, scene: &SceneFile, view: &View, s: &mut FrameStats, pvs: &mut Vec<NodeId>) -> HcStats {
        let t = Instant::now();
        let hc = frustum_cull(scene.nodes(), view, self.tau, pvs);
        s.hc_ms = ms(t);
        hc
    }

    /// sw, chc and ovc: the hierarchy front to back, each box tested against the depth drawn
    /// so far (CHC fig. 2; Bartz 1999 sec. 3.3-3.5 with ovc's knobs).
    fn ordered(
        &mut self,
        r: &mut Renderer,
        scene: &SceneFile,
        view: &View,
        s: &mut FrameStats,
        pvs: &mut Vec<NodeId>,
    ) -> Result<HcStats, RenderError> {
        let t = Instant::now();
        r.draw(scene, view, &[], Pass::Depth, Load::Clear)?;
        let nodes = scene.nodes();
        let chc = self.chc.get_or_insert_with(|| ChcState::new(scene.bvh_count()));
        let opts = if self.mode == Mode::Ovc { self.ovc } else { OvcOptions::default() };
        // Eq. 2: T_budget = T_render of the previous frame times F (none on the first).
        let budget_ms = opts.budget.zip(self.last_render_ms).map(|(f, render)| f * render);
        let test = if opts.adaptive > 0.0 { BoxTest::ExactCount } else { BoxTest::Exact };
        let lines = opts.sampling.max(1);
        let sampling = Sampling { lines, first: self.frames % lines };
        let mut occ = InterleavedTester::new(GpuTester { sampling, ..GpuTester::new(r, scene, test) });
        let hc = match self.mode {
            Mode::Chc => chc.frame(nodes, view, self.tau, &mut occ, pvs),
            _ => ovc(Cut { nodes, view, tau: self.tau }, &opts, budget_ms, &mut occ, &mut || ms(t), pvs),
        };
        let hc = hc.and_then(|hc| occ.finish(view).map(|()| hc))?;
        s.hc_ms = ms(t);
        Ok(hc)
    }

    /// hzb: Peng 2014's occluders drawn, the depth read back, boxes tested on its pyramid.
    fn hzb(
        &self,
        r: &mut Renderer,
        scene: &SceneFile,
        view: &View,
        s: &mut FrameStats,
        pvs: &mut Vec<NodeId>,
    ) -> Result<HcStats, RenderError> {
        let t = Instant::now();
        let nodes = scene.nodes();
        let occluders = select_occluders(nodes, scene.bvh_count(), view, ACTIVE_OCCLUDERS);
        let or = r.draw(scene, view, &occluders, Pass::Depth, Load::Clear)?;
        let depth = r.read_depth()?;
        s.take_or(&or, ms(t));
        let t = Instant::now();
        let pyramid = Pyramid::new(view.width, view.height, depth);
        let Ok(hc) = hardware_cull(nodes, view, self.tau, &mut HzbTester { nodes, pyramid: &pyramid, read: Read::at(0) }, pvs);
        s.hc_ms = ms(t);
        Ok(hc)
    }

    /// prev: the switch's OR and HC on one GPU (occlusion switch alg. 4.2), and how its RVG
    /// draws.
    fn prev(
        &mut self,
        r: &mut Renderer,
        scene: &SceneFile,
        view: &View,
        s: &mut FrameStats,
        pvs: &mut Vec<NodeId>,
    ) -> Result<(HcStats, Rvg), RenderError> {
        let t = Instant::now();
        diff(&self.older, &self.visible, &mut self.added, &mut self.removed);
        let mut or = DrawStats::default();
        for (ids, load) in [(&self.older, Load::Clear), (&self.added, Load::Keep)] {
            or = or + pass::or(r, scene, view, pass::Occluders { ids, tau: self.tau, load }, &mut self.occluders)?;
        }
        s.take_or(&or, ms(t));
        let t = Instant::now();
        let opts = HcOptions { tau: self.tau, test: self.hc, adaptive: self.ovc.adaptive, ..HcOptions::default() };
        let hc = pass::hc(r, scene, view, opts, &self.visible, &mut self.seen[self.frames as usize % 2], pvs)?;
        (s.hc_traversal_ms, s.hc_second_look_ms, s.hc_retest_ms) = (hc.times.traversal_ms, hc.times.second_look_ms, hc.times.retest_ms);
        let mut notes = None;
        if let Some(p) = hc.pyramid {
            // With the cluster occlusion test, HC notes which clusters of its visible set are
            // hidden (pass::note_clusters): RVG draws only the others, as the switch's display.
            if r.options().cluster_tests.occlusion {
                notes = Some(pass::note_clusters(scene, view, pvs, &p)?);
            }
            r.give_back(p);
        }
        // HC's time includes its notes: RVG of this frame waits for them.
        s.hc_ms = ms(t);
        // On one GPU, RVG draws over the depth OR and HC left (Yoon 2003 sec. 5.4 draws their
        // occluders into the image; here they fill the depth, so that RVG shades about one
        // fragment a pixel). That depth holds only the PVS's surfaces or ones behind them,
        // unless adaptive culling dropped visible nodes or sec. 4.7.2's pixel count stopped a
        // node at a coarser LOD than OR drew: then RVG draws on a cleared buffer, as the
        // switch's display does. A run that counts the fragments of the visible set counts
        // them on a cleared buffer too.
        let over = self.ovc.adaptive == 0.0 && !r.counts_fragments() && hc.stats.pixel_stops == 0;
        Ok((hc.stats, Rvg::Switch { notes, pass: if over { Pass::ColorOver } else { Pass::Color } }))
    }
}

/// How RVG draws a frame's visible set.
enum Rvg {
    /// The baselines, and frames that skip occlusion culling: the whole set in colour on a
    /// cleared buffer, as their papers draw it.
    Plain,
    /// prev: the switch's RVG ([`pass::rvg`]), of each node the clusters HC's notes take.
    Switch { notes: Option<VisibleClusters>, pass: Pass },
}
