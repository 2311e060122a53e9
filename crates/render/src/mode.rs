//! Culling modes and their per-frame algorithms. Each frame reads as a list of passes, each
//! timed: OR (occluders), HC (the cull), RVG (drawing the visible set).
//!
//! - `vfc`: frustum culling only, LODs at tau.
//! - `sw`: hierarchical stop-and-wait tests, front to back (paper 001 sec. 3.3): `ovc` without
//!   its knobs.
//! - `ovc`: paper 003's depth-ordered interleaved culling, with adaptive culling (eq. 1), the
//!   cost-adaptive budget (eq. 2) and interleaved sampling of the box tests (sec. 3.3).
//! - `chc`: coherent hierarchical culling (paper 001 fig. 2), batched for wgpu's readback.
//! - `hzb`: GigaWalk-like (paper 002 sec. 5.2-5.3): occluders picked by eq. 3 drawn at full
//!   detail, depth read back, a Z pyramid built and boxes tested on the CPU.
//! - `prev`: the occlusion switch's algorithm on one GPU (paper 004 fig. 5, paper 000 alg.
//!   4.2), exactly as the two switch nodes run it: the OR of frame i happens while HC of frame
//!   i-1 is still streaming, so it draws the front of V(i-2) updated for camera i (sec. 4.6),
//!   then the additions of frame i-1 as they arrive, into the depth buffer; HC tests the
//!   hierarchy against it (alg. 4.1); RVG draws V(i).
//! - `switch`: the same on two nodes and a display (`osw run`, crates/node); not a mode of
//!   [`ModeState`], named here so that runs, reports and results share one enum.

use crate::stats::FrameStats;
use osw_cull::chc::ChcState;
use osw_cull::cluster::ClusterHistory;
use osw_cull::delta::diff;
use osw_cull::front::update_front;
use osw_cull::hzb::{ACTIVE_OCCLUDERS, Footprint, HzbTester, Pyramid, select_occluders};
use osw_cull::ovc::{OvcOptions, ovc};
use osw_cull::payoff::Alternating;
use osw_cull::retest::retest_additions;
use osw_cull::{AllVisible, HcStats, View, VisibilityTester, hardware_cull, hardware_cull_from};
use osw_gpu::draw::Pass;
use osw_gpu::renderer::{BoxTest, DrawStats, GpuTester, InterleavedTester, RenderError, Renderer};
use osw_scene::NodeId;
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
    pub fn on_one_gpu(self) -> Result<(), String> {
        match self {
            Mode::Switch => {
                Err("--mode switch: the switch runs on two nodes and a display, `osw run` (its algorithm on one GPU is prev)".into())
            }
            _ => Ok(()),
        }
    }

    /// The modes with adaptive culling (paper 003 eq. 1): ovc in its traversal, prev and the
    /// switch in HC's exact tests.
    pub fn adaptive(self) -> bool {
        matches!(self, Mode::Ovc | Mode::Prev | Mode::Switch)
    }
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

/// How prev's HC tests boxes (`osw render --hc`); the switch's nodes use the hybrid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HcTest {
    /// The depth read back once and a farthest-depth pyramid on the CPU (every traversal
    /// round tested without a round trip), then the PVS's boxes that are small on screen
    /// tested again against the same pyramid read finer. Large boxes stay visible: they are
    /// nearly always visible, and their children are tested.
    #[default]
    Hybrid,
    /// [`BoxTest::Exact`], with pixel counts when tau > 0 (the LOD stop of sec. 4.7.2).
    Exact,
    /// [`BoxTest::Pyramid`]: the pyramid in compute, a GPU round trip per round.
    Pyramid,
    /// [`BoxTest::Queries`]: one occlusion query per box, the paper's; the slow reference.
    Queries,
}

impl HcTest {
    pub const ALL: [HcTest; 4] = [HcTest::Hybrid, HcTest::Exact, HcTest::Pyramid, HcTest::Queries];

    pub fn name(self) -> &'static str {
        match self {
            HcTest::Hybrid => "hybrid",
            HcTest::Exact => "exact",
            HcTest::Pyramid => "pyramid",
            HcTest::Queries => "queries",
        }
    }
}

impl std::str::FromStr for HcTest {
    type Err = String;
    fn from_str(s: &str) -> Result<HcTest, String> {
        HcTest::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("unknown HC test {s:?}: expected hybrid, pyramid, exact or queries"))
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
    chc: Option<ChcState>,
    /// RVG's visible clusters of the last frame (prev).
    clusters: ClusterHistory,
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

/// The OR pass's draw, shared by `prev` and the switch node: `ids` re-selected for `view` at
/// `tau` (the front update of sec. 4.6) drawn into the depth buffer; `clear` starts a new one.
/// OR draws the front of V(i-2), then HC's additions of frame i-1 as they arrive: HC chose
/// those for camera i-1, so they are re-selected too and every occluder is geometry at tau
/// for camera i (tau may also change between frames). `front` is scratch space kept across
/// frames.
pub fn draw_occluders(
    r: &mut Renderer,
    view: &View,
    ids: &[NodeId],
    tau: f64,
    clear: bool,
    front: &mut Vec<NodeId>,
) -> Result<DrawStats, RenderError> {
    update_front(r.scene.nodes(), ids, view, tau, front);
    r.draw(view, front, Pass::Depth, clear)
}

/// `--hc hybrid`'s first test reads the CPU pyramid this many levels finer than GigaWalk's
/// 2x2 texels (a box spans at most 16 texels a side), as the GPU pyramid test does.
const HYBRID_FINER: u32 = 3;

/// `--hc hybrid` tests the PVS's boxes at most this many pixels across again. Larger boxes
/// are nearly always visible.
const HYBRID_SECOND_PX: f64 = 512.0;

/// The second look reads the pyramid this many levels finer than GigaWalk's 2x2 texels: at
/// most 128 texels a side, 16K reads for the largest box. Measured on the 5M plant walk at
/// tau 5 (issue 16's closing note), against the exact GPU test it replaced: it drops 85 boxes a
/// frame where the exact test dropped 102 and costs 0.8 ms where that cost 10 (one core); 5
/// levels drop 77, 8 levels 88.5 for 3 ms.
const HYBRID_SECOND_FINER: u32 = 6;

/// `--hc hybrid`'s tester: boxes against the CPU pyramid of the depth buffer, which new
/// occluders found by the traversal join, at least `min` at a time (drawn, the depth read
/// back and the pyramid rebuilt: about as much as drawing them costs again).
struct HybridTester<'a> {
    r: &'a mut Renderer,
    pyramid: Pyramid,
    min: usize,
    /// The new occluders drawn so far (HC's second pass need not draw them again).
    drawn: Vec<NodeId>,
    error: Option<RenderError>,
}

/// New occluders worth a depth read-back and a pyramid (see [`HybridTester`]). Measured on
/// the plant walks of `scripts/scale.sh` (2M, 20M, 100M): 64 and 128 halve HC's tests at
/// 100M but read back on most frames (HC 13 → 23 ms at 20M); 256 reads back only where a
/// region comes into view, and 512 leaves most of those frames' tests.
pub const NEW_OCCLUDERS_MIN: usize = 256;

impl VisibilityTester for HybridTester<'_> {
    fn test(&mut self, view: &View, ids: &[NodeId], out: &mut Vec<osw_cull::Visibility>) {
        let scene = std::sync::Arc::clone(&self.r.scene);
        HzbTester { nodes: scene.nodes(), pyramid: &self.pyramid, finer: HYBRID_FINER }.test(view, ids, out);
    }

    fn add_occluders(&mut self, view: &View, lods: &[NodeId]) -> bool {
        if self.error.is_some() || lods.len() < self.min {
            return false;
        }
        let depth = self.r.draw(view, lods, Pass::Depth, false).and_then(|_| Ok(self.r.target.read_depth(&self.r.gpu)?));
        match depth {
            Ok(d) => self.pyramid = Pyramid::new(view.width, view.height, d),
            Err(e) => self.error = Some(e),
        }
        self.drawn.extend_from_slice(lods);
        true
    }
}

/// Additions from which `hc_pass` tests them again through the hierarchy
/// ([`retest_additions`], a GPU round trip per level) rather than box by box (one round trip).
const RETEST_HIERARCHY_MIN: usize = 128;

/// The HC pass of the switch (paper 000 alg. 4.1) against the depth buffer as the OR pass left
/// it, shared by `prev` and the switch node: appends the PVS, sorted and without duplicates.
/// `previous` is V(i-1) (sorted), which OR drew as occluders; the nodes above it are taken as
/// visible, so the tests are its front, in about one round (see osw_cull::hc).
///
/// With `hybrid` (the default) the depth buffer is read back once and every round is tested
/// on the CPU against its farthest-depth pyramid: sec. 4.7.1 batches a level per round trip
/// because a 2003 query cost more than the trip; here a trip (a few ms on lavapipe, with the
/// GPU pyramid's dispatches) costs more than a thousand CPU box tests.
///
/// Then a second pass, as in two-phase occlusion culling (zeux's niagara): nodes found visible
/// that are not in V(i-1) had nothing drawn for them. Where a region comes into view (a turn,
/// a disocclusion) there are no occluders at all, so everything behind it is found visible for
/// one frame and gone the next, sent to RVG and the peer twice. Those additions are drawn into
/// the depth buffer and tested again, exactly; the ones hidden behind others are dropped.
/// Conservative: only geometry of this frame's PVS is added as occluder. The hybrid first
/// tests every small box of the PVS again against its pyramid read finer (the depth buffer as
/// its traversal left it: OR's, and the new occluders it took). `pvs` comes in empty.
pub fn hc_pass(
    r: &mut Renderer,
    view: &View,
    tau: f64,
    hc: HcTest,
    adaptive: f64,
    previous: &[NodeId],
    pvs: &mut Vec<NodeId>,
) -> Result<HcStats, RenderError> {
    hc_pass_with(r, view, tau, hc, adaptive, previous, pvs, NEW_OCCLUDERS_MIN)
}

/// [`hc_pass`], the hybrid taking new occluders `new_occluders_min` at a time.
#[allow(clippy::too_many_arguments)]
pub fn hc_pass_with(
    r: &mut Renderer,
    view: &View,
    tau: f64,
    hc: HcTest,
    adaptive: f64,
    previous: &[NodeId],
    pvs: &mut Vec<NodeId>,
    new_occluders_min: usize,
) -> Result<HcStats, RenderError> {
    let scene = std::sync::Arc::clone(&r.scene);
    let nodes = scene.nodes();
    // Without V(i-1) OR drew no occluder (the first frame, or one that saw nothing): every
    // test would pass, so none is made.
    let occluders = !previous.is_empty();
    // New occluders the traversal drew (the hybrid's).
    let mut drawn = Vec::new();
    // The hybrid's pyramid of the depth buffer as its traversal left it.
    let mut hybrid_pyramid = None;
    let stats = if !occluders {
        hardware_cull(nodes, view, tau, &mut AllVisible, pvs)
    } else if hc == HcTest::Hybrid {
        let pyramid = Pyramid::new(view.width, view.height, r.target.read_depth(&r.gpu)?);
        let mut tester = HybridTester { r, pyramid, min: new_occluders_min, drawn: Vec::new(), error: None };
        let stats = hardware_cull_from(nodes, view, tau, previous, &mut tester, pvs);
        if let Some(e) = tester.error {
            return Err(e);
        }
        drawn = tester.drawn;
        drawn.sort_unstable();
        hybrid_pyramid = Some(tester.pyramid);
        stats
    } else {
        let test = match hc {
            HcTest::Pyramid => {
                r.build_pyramid();
                BoxTest::Pyramid
            }
            HcTest::Queries => BoxTest::Queries,
            // Pixel counts only matter when the sec. 4.7.2 stop can trigger (tau > 0).
            _ if tau > 0.0 => BoxTest::ExactCount,
            _ => BoxTest::Exact,
        };
        let mut tester = GpuTester { renderer: r, test, error: None };
        let stats = hardware_cull_from(nodes, view, tau, previous, &mut tester, pvs);
        if let Some(e) = tester.error {
            return Err(e);
        }
        stats
    };
    pvs.sort_unstable();
    pvs.dedup();
    // The triangles of what the traversal found: the retests only drop from it.
    let found = osw_cull::payoff::triangles(nodes, pvs);
    let mut tests = stats.tests;
    // Hidden boxes, and of those the ones only adaptive culling dropped.
    let mut hidden = (0, 0);
    // The hybrid's second look at every small box of the PVS, before the additions are drawn:
    // what the traversal's coarse rectangles let through would otherwise be drawn as an
    // addition, dropped, and found again the next frame. The same pyramid read finer, or with
    // adaptive culling, which scores pixel counts, exactly on the GPU.
    if let Some(pyramid) = &hybrid_pyramid {
        let vp = view.view_proj().as_dmat4();
        let small: Vec<NodeId> =
            pvs.iter().copied().filter(|&id| Footprint::of(nodes, &vp, view, id).span_px() <= HYBRID_SECOND_PX).collect();
        let d = if adaptive > 0.0 {
            drop_hidden(r, view, &small, adaptive, pvs)?
        } else {
            let mut seen = Vec::with_capacity(small.len());
            HzbTester { nodes, pyramid, finer: HYBRID_SECOND_FINER }.test(view, &small, &mut seen);
            let dropped: Vec<NodeId> = small.iter().zip(&seen).filter(|(_, v)| !v.visible).map(|(&id, _)| id).collect();
            pvs.retain(|id| dropped.binary_search(id).is_err());
            (dropped.len() as u32, 0)
        };
        (tests, hidden) = (tests + small.len() as u32, (hidden.0 + d.0, hidden.1 + d.1));
    }
    let (added, kept): (Vec<NodeId>, Vec<NodeId>) = pvs.iter().partition(|id| previous.binary_search(id).is_err());
    if !added.is_empty() {
        let undrawn: Vec<NodeId> = added.iter().copied().filter(|id| drawn.binary_search(id).is_err()).collect();
        if !undrawn.is_empty() {
            r.draw(view, &undrawn, Pass::Depth, false)?;
        }
        // Box by box when few (one round trip), or where paper 003's eq. 1 scores each
        // addition's own pixels; through the hierarchy when many (a region came into view).
        // Exactly on the GPU, also in the hybrid: measured, its pyramid read finer kept 18%
        // more nodes (issue 16's closing note).
        if adaptive > 0.0 || added.len() < RETEST_HIERARCHY_MIN {
            let d = drop_hidden(r, view, &added, adaptive, pvs)?;
            (tests, hidden) = (tests + added.len() as u32, (hidden.0 + d.0, hidden.1 + d.1));
        } else {
            let mut tester = GpuTester { renderer: r, test: BoxTest::Exact, error: None };
            let mut still = Vec::new();
            let s = retest_additions(nodes, view, &kept, &added, &mut tester, &mut still);
            if let Some(e) = tester.error {
                return Err(e);
            }
            tests += s.tests;
            hidden.0 += added.len().saturating_sub(still.len()) as u32;
            *pvs = kept;
            pvs.extend(still);
            pvs.sort_unstable();
        }
    }
    let retests = tests - stats.tests;
    let culled_triangles = stats.culled_triangles + found - osw_cull::payoff::triangles(nodes, pvs);
    Ok(HcStats {
        tests,
        retests,
        occlusion_culled: stats.occlusion_culled + hidden.0,
        adaptive_culled: hidden.1,
        culled_triangles,
        ..stats
    })
}

/// Tests the boxes of `ids` (sorted, in `pvs`) exactly against the depth buffer as it is and
/// removes the hidden ones from `pvs`, and with `adaptive` > 0 also those whose visible pixels
/// score under it by paper 003's eq. 1 ([`osw_cull::ovc::adapcull`]): the switch's
/// approximate knob, applied where HC tests exactly. Returns how many it removed, and how many
/// of those only adaptive culling did. As in HC, boxes around the eye or across the near plane
/// are not tested.
fn drop_hidden(r: &mut Renderer, view: &View, ids: &[NodeId], adaptive: f64, pvs: &mut Vec<NodeId>) -> Result<(u32, u32), RenderError> {
    let ids: Vec<NodeId> = ids.iter().copied().filter(|&id| !view.frustum.needs_no_test(&r.scene.node(id).aabb())).collect();
    if ids.is_empty() {
        return Ok((0, 0));
    }
    let mut seen = Vec::with_capacity(ids.len());
    r.test_boxes(view, &ids, if adaptive > 0.0 { BoxTest::ExactCount } else { BoxTest::Exact }, &mut seen)?;
    let faint =
        |id: NodeId, px: Option<u32>| px.is_some_and(|p| osw_cull::ovc::adapcull(view, &r.scene.node(id).aabb(), p as f64) < adaptive);
    let mut dropped = (0, 0);
    let hidden: Vec<NodeId> = ids
        .iter()
        .zip(&seen)
        .filter(|&(&id, v)| {
            let drop = !v.visible || (adaptive > 0.0 && faint(id, v.pixels));
            dropped = (dropped.0 + u32::from(drop), dropped.1 + u32::from(drop && v.visible));
            drop
        })
        .map(|(&id, _)| id)
        .collect();
    pvs.retain(|id| hidden.binary_search(id).is_err());
    Ok(dropped)
}

impl ModeState {
    /// A mode's state, or why it cannot run on one GPU (the switch).
    pub fn new(mode: Mode, tau: f64, hc: HcTest) -> Result<ModeState, String> {
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
            chc: None,
            clusters: ClusterHistory::default(),
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

    /// Renders one frame for `view` into the renderer's colour target.
    pub fn frame(&mut self, r: &mut Renderer, view: &View) -> Result<FrameStats, RenderError> {
        r.begin_frame();
        let mut s = FrameStats::default();
        let scene = std::sync::Arc::clone(&r.scene);
        let nodes = scene.nodes();
        let mut pvs = Vec::new();
        // Whether this frame's occlusion culling is expected to pay (prev and chc; see
        // osw_cull::payoff), from the counts of the last frame judged.
        let frame = self.frames as u64;
        let cull = !matches!(self.mode, Mode::Prev | Mode::Chc) || self.payoff.as_mut().is_none_or(|p| p.of(frame).cull());
        s.cull_skipped = u32::from(!cull);
        // A frame that skips occlusion culling is frustum culled.
        let hc: HcStats = match if cull { self.mode } else { Mode::Vfc } {
            Mode::Vfc => {
                let t = Instant::now();
                let hc = hardware_cull(nodes, view, self.tau, &mut AllVisible, &mut pvs);
                s.hc_ms = ms(t);
                hc
            }
            Mode::Sw | Mode::Chc | Mode::Ovc => {
                let t = Instant::now();
                r.draw(view, &[], Pass::Depth, true)?;
                let chc = self.chc.get_or_insert_with(|| ChcState::new(scene.bvh_count()));
                let opts = if self.mode == Mode::Ovc { self.ovc } else { OvcOptions::default() };
                // Eq. 2: T_budget = T_render of the previous frame times F (none on the first).
                let budget_ms = opts.budget.zip(self.last_render_ms).map(|(f, render)| f * render);
                r.sampling = (opts.sampling.max(1), self.frames % opts.sampling.max(1));
                let mut occ = InterleavedTester::new(r);
                if opts.adaptive > 0.0 {
                    occ.tester.test = BoxTest::ExactCount;
                }
                let hc = match self.mode {
                    Mode::Chc => chc.frame(nodes, view, self.tau, &mut occ, &mut pvs),
                    _ => ovc(nodes, view, self.tau, &opts, budget_ms, &mut occ, &mut || ms(t), &mut pvs),
                };
                // Sampled tests are ovc's alone: back to reading every line, also after an error.
                let finished = occ.finish(view);
                r.sampling = (1, 0);
                finished?;
                s.hc_ms = ms(t);
                hc
            }
            Mode::Hzb => {
                let t = Instant::now();
                let occluders = select_occluders(nodes, scene.bvh_count(), view, ACTIVE_OCCLUDERS);
                let or = r.draw(view, &occluders, Pass::Depth, true)?;
                let depth = r.target.read_depth(&r.gpu)?;
                (s.or_ms, s.or_nodes, s.or_triangles) = (ms(t), or.nodes, or.triangles);
                let t = Instant::now();
                let pyramid = Pyramid::new(view.width, view.height, depth);
                let hc = hardware_cull(nodes, view, self.tau, &mut HzbTester { nodes, pyramid: &pyramid, finer: 0 }, &mut pvs);
                s.hc_ms = ms(t);
                hc
            }
            // The switch's algorithm on one GPU (`new` refuses the switch itself).
            Mode::Prev | Mode::Switch => {
                let t = Instant::now();
                diff(&self.older, &self.visible, &mut self.added, &mut self.removed);
                let front = draw_occluders(r, view, &self.older, self.tau, true, &mut self.occluders)?;
                let added = draw_occluders(r, view, &self.added, self.tau, false, &mut self.occluders)?;
                (s.or_ms, s.or_nodes, s.or_triangles) = (ms(t), front.nodes + added.nodes, front.triangles + added.triangles);
                let t = Instant::now();
                let hc = hc_pass(r, view, self.tau, self.hc, self.ovc.adaptive, &self.visible, &mut pvs)?;
                s.hc_ms = ms(t);
                hc
            }
        };
        // One draw order for every mode: sorted ids, so equal sets give equal pixels even
        // where surfaces tie in depth.
        pvs.sort_unstable();
        pvs.dedup();
        // A frame without occluders (prev's first, or one after a view of nothing) culls
        // nothing, whatever culling would save: it is not judged.
        let judged = cull && (self.mode == Mode::Chc || (self.mode == Mode::Prev && !self.visible.is_empty()));
        if let Some(p) = self.payoff.as_mut().filter(|_| judged) {
            p.of(frame).judge_hc(nodes, &hc, &pvs);
        }
        // RVG: the switch's (prev) culls hidden clusters too; the baselines draw as their papers.
        let t = Instant::now();
        let drawn = match self.mode {
            Mode::Prev | Mode::Switch => r.draw_visible(view, &pvs, Pass::Color, &mut self.clusters)?,
            _ => r.draw(view, &pvs, Pass::Color, true)?,
        };
        s.rvg_ms = ms(t);
        s.total_ms = s.or_ms + s.hc_ms + s.rvg_ms;
        (self.last_render_ms, self.frames) = (Some(s.rvg_ms), self.frames + 1);
        (s.pvs_nodes, s.triangles_drawn) = (drawn.nodes, drawn.triangles);
        s.fragments = r.counts_fragments().then_some(drawn.fragments);
        let c = drawn.clusters;
        (s.clusters, s.clusters_frustum_culled, s.clusters_cone_culled, s.clusters_occlusion_culled) =
            (c.clusters, c.frustum_culled, c.cone_culled, c.occlusion_culled);
        (s.triangles_backface_culled, s.triangles_small_culled) = (c.backface_culled, c.small_culled);
        (s.tests, s.retests, s.levels, s.frustum_culled, s.occlusion_culled, s.pixel_stops) =
            (hc.tests, hc.retests, hc.levels, hc.frustum_culled, hc.occlusion_culled, hc.pixel_stops);
        (s.adaptive_culled, s.over_budget) = (hc.adaptive_culled, hc.over_budget);
        self.older = std::mem::replace(&mut self.visible, pvs);
        Ok(s)
    }
}
