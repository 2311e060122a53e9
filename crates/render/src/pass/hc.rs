//! HC, hardware culling (occlusion switch sec. 4.7): the hierarchy tested against the depth
//! buffer OR left, in three timed passes: the traversal, the hybrid's second look at small
//! boxes, and the retest of the additions drawn as occluders.

use osw_cull::hc::nearest_in_view;
use osw_cull::hzb::{Footprint, HzbTester, PYRAMID_FINER, Pyramid, Read};
use osw_cull::retest::retest_additions;
use osw_cull::{HcStats, View, VisibilityTester, frustum_cull, hardware_cull_seen};
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{BoxTest, RenderError, Renderer};
use osw_gpu::testers::GpuTester;
use osw_scene::{NodeId, SceneFile};
use std::time::Instant;

/// How prev's HC tests boxes (`osw render --hc`); the switch's nodes use the hybrid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HcTest {
    /// The depth read back once and a farthest-depth pyramid on the CPU (every traversal
    /// round tested without a round trip), then the PVS's boxes that are small on screen or
    /// not in V(i-1) tested again against the same pyramid read finer. Large boxes of V(i-1)
    /// stay visible: they are nearly always visible, and their children are tested.
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

/// `--hc hybrid` tests the PVS's boxes at most this many pixels across again, and those not in
/// V(i-1) whatever their size. Larger boxes of V(i-1) are nearly always visible.
const HYBRID_SECOND_PX: f64 = 512.0;

/// How the second look reads the pyramid: from 4 levels finer than Peng 2014's 2x2 texels (at
/// most 32 texels a side) down to the pixels, block by block: nearly the exact GPU test's
/// culling at a tenth of its time, and fine enough that a large near box stays within the
/// pixel budget (docs/measurements/2026-12-07-constants.md, "SECOND_LOOK_READ").
const SECOND_LOOK_READ: Read = Read { finer: 4, budget: PIXELS_BUDGET, by_block: true };

/// How the hybrid's traversal tests a box against its pyramid: texels read below the box's
/// level, down to the pixels under it (osw_cull::hzb::Pyramid::reaches), and there by the
/// box's own depth at the pixel centres it covers ([`osw_cull::hzb::PixelRays`], as the exact
/// GPU test draws it). The coarse test let through boxes that the retest's exact GPU test
/// then hid, the same ones every frame, each reached by a chain of tests from a visible
/// ancestor; read to the pixels, HC makes fewer tests in less time, and halving a box that
/// passes no longer pays (docs/measurements/2026-12-03-hc-tests.md,
/// docs/measurements/2026-12-05-hc-notes.md).
const TRAVERSAL_READ: Read = Read { finer: PYRAMID_FINER, budget: PIXELS_BUDGET, by_block: false };
const PIXELS_BUDGET: u32 = 1024;

/// `--hc hybrid`'s tester: boxes against the CPU pyramid of the depth buffer, which new
/// occluders found by the traversal join, at least `min` at a time (drawn, the depth read
/// back and the pyramid rebuilt: about as much as drawing them costs again).
struct HybridTester<'a> {
    r: &'a mut Renderer,
    scene: &'a SceneFile,
    pyramid: Pyramid,
    min: usize,
    /// New occluders not hidden by the pyramid, not drawn yet.
    pending: Vec<NodeId>,
    /// The new occluders drawn so far (the retest need not draw them again).
    drawn: Vec<NodeId>,
}

impl HybridTester<'_> {
    fn hzb(&self) -> HzbTester<'_> {
        HzbTester { nodes: self.scene.nodes(), pyramid: &self.pyramid, read: TRAVERSAL_READ }
    }
}

/// New occluders worth a depth read-back and a pyramid (see [`HybridTester`]): a round (a
/// draw, a read-back, a pyramid) must save more tests than it costs, and with each pixel read
/// by the box's own depth few boxes pass but where a region comes into view. There CHC draws
/// what it finds before it tests what lies behind; the fewer new occluders HC waits for, the
/// nearer its tests come to CHC's, at a read-back each round (docs/measurements/2026-12-06-same-tau.md,
/// "Fewer rounds"; docs/measurements/2026-12-07-hc-walks.md).
pub const NEW_OCCLUDERS_MIN: usize = 4;

impl VisibilityTester for HybridTester<'_> {
    type Error = RenderError;

    fn test(&mut self, view: &View, ids: &[NodeId], out: &mut Vec<osw_cull::Visibility>) -> Result<(), RenderError> {
        let Ok(()) = self.hzb().test(view, ids, out);
        Ok(())
    }

    /// Takes every offer: the LODs whose own boxes the pyramid hides are left out (hidden, they
    /// write no depth; the traversal passed their BVH node's box, and an HLOD's box is often
    /// smaller: a far group seen through a gap beside it), the others drawn once `min` wait.
    fn add_occluders(&mut self, view: &View, lods: &[NodeId]) -> Result<bool, RenderError> {
        let mut seen = Vec::with_capacity(lods.len());
        let Ok(()) = self.hzb().test(view, lods, &mut seen);
        self.pending.extend(lods.iter().zip(&seen).filter(|(_, v)| v.visible).map(|(&id, _)| id));
        if self.pending.len() >= self.min {
            self.r.draw_opaque(self.scene, view, &self.pending, Pass::Depth, Load::Keep)?;
            self.r.give_back(std::mem::take(&mut self.pyramid));
            self.pyramid = self.r.depth_pyramid()?;
            self.drawn.append(&mut self.pending);
        }
        Ok(true)
    }
}

/// Additions from which [`hc`] tests them again through the hierarchy
/// ([`retest_additions`], a GPU round trip per level) rather than box by box (one round trip).
const RETEST_HIERARCHY_MIN: usize = 128;

/// How HC culls a frame.
#[derive(Clone, Copy, Debug)]
pub struct HcOptions {
    /// Pixels of error the LOD selection allows (the camera's, as the frame's).
    pub tau: f64,
    pub test: HcTest,
    /// Adaptive culling's threshold in the exact tests (Bartz 1999 eq. 1; 0: conservative).
    pub adaptive: f64,
    /// New occluders the hybrid's traversal takes at a time ([`NEW_OCCLUDERS_MIN`]).
    pub new_occluders_min: usize,
}

impl Default for HcOptions {
    fn default() -> HcOptions {
        HcOptions { tau: 0.0, test: HcTest::Hybrid, adaptive: 0.0, new_occluders_min: NEW_OCCLUDERS_MIN }
    }
}

/// CPU time of HC's passes, ms: each includes its GPU round trips.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HcTimes {
    pub traversal_ms: f64,
    pub second_look_ms: f64,
    pub retest_ms: f64,
}

/// What HC did: its counts, its passes' times, the additions it drew as occluders (sorted),
/// and the hybrid's pyramid of the depth buffer as its traversal left it.
#[derive(Default)]
pub struct HcPass {
    pub stats: HcStats,
    pub times: HcTimes,
    pub drawn: Vec<NodeId>,
    pub pyramid: Option<Pyramid>,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// HC (occlusion switch alg. 4.1) against the depth buffer as OR left it, shared by `prev` and
/// the switch node: appends the PVS to `pvs` (empty), sorted and without duplicates.
/// `previous` is V(i-1) (sorted), which OR drew as occluders; the nodes above it, and the
/// nodes in `seen` that an earlier traversal found visible, are taken as visible, so the
/// tests are its front, in about one round (see osw_cull::hc); `seen` then holds this
/// traversal's. Three passes:
///
/// 1. The traversal ([`traverse`]). With `hybrid` (the default) the depth buffer is read back
///    once and every round is tested on the CPU against its farthest-depth pyramid: sec. 4.7.1
///    batches a level per round trip because a 2003 query cost more than the trip; here a trip
///    (a few ms on lavapipe, with the GPU pyramid's dispatches) costs more than a thousand CPU
///    box tests.
/// 2. The hybrid's second look ([`second_look`]): the PVS's small and new boxes against its pyramid
///    read finer.
/// 3. The retest ([`retest`]), as in two-phase occlusion culling (niagara): nodes found
///    visible that are not in V(i-1) had nothing drawn for them. Where a region comes into
///    view (a turn, a disocclusion) there are no occluders at all, so everything behind it is
///    found visible for one frame and gone the next, sent to RVG and the peer twice. Those
///    additions are drawn into the depth buffer and tested again, exactly.
pub fn hc(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    opts: HcOptions,
    previous: &[NodeId],
    seen: &mut Vec<NodeId>,
    pvs: &mut Vec<NodeId>,
) -> Result<HcPass, RenderError> {
    let t = Instant::now();
    let traversal = traverse(r, scene, view, opts, previous, seen, pvs)?;
    let nodes = scene.nodes();
    // The triangles of what the traversal found: the later passes only drop from it.
    let found = osw_cull::payoff::triangles(nodes, pvs);
    let traversal_ms = ms(t);
    let t = Instant::now();
    let mut look = Dropped::default();
    if let Some(pyramid) = &traversal.pyramid {
        look = second_look(r, scene, view, opts.adaptive, previous, pyramid, pvs)?;
    }
    let second_look_ms = ms(t);
    let t = Instant::now();
    let (again, retest_drawn) = retest(r, scene, view, opts.adaptive, previous, &traversal.drawn, pvs)?;
    let retest_ms = ms(t);
    let stats = traversal.stats;
    let retests = look.tests + again.tests;
    let culled_triangles = stats.culled_triangles + found - osw_cull::payoff::triangles(nodes, pvs);
    Ok(HcPass {
        stats: HcStats {
            tests: stats.tests + retests,
            retests,
            occlusion_culled: stats.occlusion_culled + look.hidden + again.hidden,
            adaptive_culled: look.adaptive + again.adaptive,
            culled_triangles,
            ..stats
        },
        times: HcTimes { traversal_ms, second_look_ms, retest_ms },
        drawn: {
            let mut drawn = traversal.drawn;
            drawn.extend(retest_drawn);
            drawn.sort_unstable();
            drawn
        },
        pyramid: traversal.pyramid,
    })
}

/// The traversal's result: its counts, the new occluders the hybrid drew (sorted), and the
/// hybrid's pyramid of the depth buffer as the traversal left it.
struct Traversal {
    stats: HcStats,
    drawn: Vec<NodeId>,
    pyramid: Option<Pyramid>,
}

/// HC's first pass: the hierarchy from V(i-1)'s front against the depth buffer; appends the
/// PVS to `pvs`, sorted and without duplicates.
fn traverse(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    opts: HcOptions,
    previous: &[NodeId],
    seen: &mut Vec<NodeId>,
    pvs: &mut Vec<NodeId>,
) -> Result<Traversal, RenderError> {
    let (nodes, tau) = (scene.nodes(), opts.tau);
    let mut t = Traversal { stats: HcStats::default(), drawn: Vec::new(), pyramid: None };
    // Without V(i-1) OR drew no occluder (the first frame, or one that saw nothing). The
    // hybrid draws the nearest of what the frustum holds first and takes it for V(i-1); the
    // other testers would pass every test, so none is made.
    let nearest;
    let previous = match previous.is_empty() && opts.test == HcTest::Hybrid {
        true => {
            nearest = nearest_in_view(nodes, view, tau, FIRST_OCCLUDER_TRIANGLES);
            r.draw_opaque(scene, view, &nearest, Pass::Depth, Load::Keep)?;
            t.drawn.extend_from_slice(&nearest);
            &nearest[..]
        }
        false => previous,
    };
    if previous.is_empty() {
        seen.clear();
        t.stats = frustum_cull(nodes, view, tau, pvs);
    } else if opts.test == HcTest::Hybrid {
        let pyramid = r.depth_pyramid()?;
        let min = opts.new_occluders_min;
        let mut tester = HybridTester { r, scene, pyramid, min, pending: Vec::new(), drawn: std::mem::take(&mut t.drawn) };
        t.stats = hardware_cull_seen(nodes, view, tau, previous, seen, &mut tester, pvs)?;
        t.drawn = tester.drawn;
        t.drawn.sort_unstable();
        t.pyramid = Some(tester.pyramid);
    } else {
        let test = match opts.test {
            HcTest::Pyramid => {
                r.build_pyramid();
                BoxTest::Pyramid
            }
            HcTest::Queries => BoxTest::Queries,
            // Pixel counts only matter when the sec. 4.7.2 stop can trigger (tau > 0).
            _ if tau > 0.0 => BoxTest::ExactCount,
            _ => BoxTest::Exact,
        };
        t.stats = hardware_cull_seen(nodes, view, tau, previous, seen, &mut GpuTester::new(r, scene, test), pvs)?;
    }
    pvs.sort_unstable();
    pvs.dedup();
    Ok(t)
}

/// Triangles of the first occluders of a frame without V(i-1) (about a frame's worth on the
/// plant walks at 1024x1024). Drawing everything the frustum holds instead, as the retest
/// would, took seconds for the first frame of the 10B instanced plant's walk
/// (docs/measurements/2026-12-04-instances-10b-walk.md, "The first frame").
const FIRST_OCCLUDER_TRIANGLES: u64 = 1 << 16;

/// Boxes a pass tested and dropped as hidden, and of those the ones only adaptive culling
/// dropped.
#[derive(Default)]
struct Dropped {
    tests: u32,
    hidden: u32,
    adaptive: u32,
}

/// The hybrid's second look: every small box of the PVS, and every box not in V(i-1)
/// (`previous`), tested again before the additions are drawn, against the traversal's pyramid
/// read finer and block by block (or, with adaptive culling, which scores pixel counts,
/// exactly on the GPU): what the traversal's coarse rectangles let through would otherwise be
/// drawn as an addition, dropped by the retest, and found again the next frame: near parts
/// behind a wall whose boxes reach off the image (docs/measurements/2026-12-05-hc-notes.md).
fn second_look(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    adaptive: f64,
    previous: &[NodeId],
    pyramid: &Pyramid,
    pvs: &mut Vec<NodeId>,
) -> Result<Dropped, RenderError> {
    let nodes = scene.nodes();
    let vp = view.view_proj().as_dmat4();
    let again = |id: NodeId| previous.binary_search(&id).is_err() || Footprint::of(nodes, &vp, view, id).span_px() <= HYBRID_SECOND_PX;
    let looked: Vec<NodeId> = pvs.iter().copied().filter(|&id| again(id)).collect();
    let (hidden, adaptive_culled) = if adaptive > 0.0 {
        drop_hidden(r, scene, view, &looked, adaptive, pvs)?
    } else {
        let mut seen = Vec::with_capacity(looked.len());
        let Ok(()) = HzbTester { nodes, pyramid, read: SECOND_LOOK_READ }.test(view, &looked, &mut seen);
        let dropped: Vec<NodeId> = looked.iter().zip(&seen).filter(|(_, v)| !v.visible).map(|(&id, _)| id).collect();
        pvs.retain(|id| dropped.binary_search(id).is_err());
        (dropped.len() as u32, 0)
    };
    Ok(Dropped { tests: looked.len() as u32, hidden, adaptive: adaptive_culled })
}

/// The third pass, as in two-phase occlusion culling (niagara): the PVS's nodes not in V(i-1)
/// had nothing drawn for them. They are drawn into the depth buffer (but for the hybrid's new
/// occluders, drawn already) and tested again, exactly; the ones hidden behind others are
/// dropped. Only geometry of this frame's PVS is added as occluder: conservative. Returns
/// also the nodes it drew.
fn retest(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    adaptive: f64,
    previous: &[NodeId],
    drawn: &[NodeId],
    pvs: &mut Vec<NodeId>,
) -> Result<(Dropped, Vec<NodeId>), RenderError> {
    let (added, kept): (Vec<NodeId>, Vec<NodeId>) = pvs.iter().partition(|id| previous.binary_search(id).is_err());
    if added.is_empty() {
        return Ok(Default::default());
    }
    let undrawn: Vec<NodeId> = added.iter().copied().filter(|id| drawn.binary_search(id).is_err()).collect();
    if !undrawn.is_empty() {
        r.draw_opaque(scene, view, &undrawn, Pass::Depth, Load::Keep)?;
    }
    // Box by box when few (one round trip), or where Bartz 1999's eq. 1 scores each addition's own
    // pixels; through the hierarchy when many (a region came into view). Exactly on the GPU,
    // also in the hybrid: measured, its pyramid read finer kept 18% more nodes.
    if adaptive > 0.0 || added.len() < RETEST_HIERARCHY_MIN {
        let (hidden, adaptive_culled) = drop_hidden(r, scene, view, &added, adaptive, pvs)?;
        return Ok((Dropped { tests: added.len() as u32, hidden, adaptive: adaptive_culled }, undrawn));
    }
    let mut still = Vec::new();
    let s = retest_additions(scene.nodes(), view, &kept, &added, &mut GpuTester::new(r, scene, BoxTest::Exact), &mut still)?;
    let hidden = added.len().saturating_sub(still.len()) as u32;
    *pvs = kept;
    pvs.extend(still);
    pvs.sort_unstable();
    Ok((Dropped { tests: s.tests, hidden, adaptive: 0 }, undrawn))
}

/// Tests the boxes of `ids` (sorted, in `pvs`) exactly against the depth buffer as it is and
/// removes the hidden ones from `pvs`, and with `adaptive` > 0 also those whose visible pixels
/// score under it by Bartz 1999's eq. 1 ([`osw_cull::ovc::adapcull`]): the switch's
/// approximate knob, applied where HC tests exactly. Returns how many it removed, and how many
/// of those only adaptive culling did. As in HC, boxes around the eye or across the near plane
/// are not tested.
fn drop_hidden(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    ids: &[NodeId],
    adaptive: f64,
    pvs: &mut Vec<NodeId>,
) -> Result<(u32, u32), RenderError> {
    let ids: Vec<NodeId> = ids.iter().copied().filter(|&id| !view.frustum.needs_no_test(&scene.node(id).aabb())).collect();
    if ids.is_empty() {
        return Ok((0, 0));
    }
    let mut seen = Vec::with_capacity(ids.len());
    let test = if adaptive > 0.0 { BoxTest::ExactCount } else { BoxTest::Exact };
    GpuTester::new(r, scene, test).test(view, &ids, &mut seen)?;
    let faint =
        |id: NodeId, px: Option<u32>| px.is_some_and(|p| osw_cull::ovc::adapcull(view, &scene.node(id).aabb(), p as f64) < adaptive);
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
