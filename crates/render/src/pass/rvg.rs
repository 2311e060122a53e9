//! RVG, the pass that draws the visible set (occlusion switch sec. 4): shared by `prev` and
//! the display, so that the switch's frames are prev's.

use osw_cull::View;
use osw_cull::cluster::{ClusterHistory, ClusterStats};
use osw_cull::hzb::{Pyramid, visible_box};
use osw_gpu::draw::{Layer, Pass};
use osw_gpu::renderer::{DrawStats, RenderError, Renderer};
use osw_scene::format::ClusterRecord;
use osw_scene::{NodeId, SceneFile};

/// RVG's cluster occlusion test reads the pyramid this many levels finer than Peng 2014's 2x2
/// texels: a box spans at most 64 texels a side. On the 5M plant walk at tau 5, 2 levels left
/// 10,246 of 13,451 triangles a frame, 5 levels 8,960 (docs/measurements/2026-12-02-clusters.md).
const CLUSTER_FINER: u32 = 5;

/// Draws `pvs` in colour. Where the frame was occlusion culled and the renderer's cluster
/// tests include occlusion, its hidden clusters are culled too ([`visible_clusters`]); a frame
/// whose culling was skipped because it did not pay (osw_cull::payoff) is drawn as vfc draws:
/// the clusters' depth read-back and pyramid are occlusion culling's cost as much as HC's
/// tests are. `history` holds the last frame's visible clusters; a frame drawn without the
/// test leaves none, so that the next culled frame finds its clusters in its second pass
/// rather than trust a view several frames old.
pub fn rvg(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    pvs: &[NodeId],
    culled: bool,
    history: &mut ClusterHistory,
) -> Result<DrawStats, RenderError> {
    if culled && r.options().cluster_tests.occlusion {
        return visible_clusters(r, scene, view, pvs, history);
    }
    *history = ClusterHistory::default();
    r.draw(scene, view, pvs, Pass::Color, true)
}

/// What OR and HC drew into the image before RVG (Yoon 2003 sec. 5.4): OR's nodes (sorted),
/// of each only the clusters visible in the last frame when RVG tests clusters for occlusion
/// (paper 004 sec. 5.3.1: the clusters visible in the last frame are the occluders), else
/// whole; and HC's additions (sorted), whole. HC's pyramid of the depth buffer, where it made
/// one, spares RVG's occlusion test a read-back.
pub struct Begun<'a> {
    pub or: &'a [NodeId],
    pub hc: &'a [NodeId],
    pub pyramid: Option<Pyramid>,
}

/// Draws `pvs` over the image that OR and HC began: the opaque clusters they did not draw
/// (with RVG's cluster occlusion test, those of them still hidden behind what is drawn are
/// skipped, [`draw_rest`]), then the translucent clusters of all, as [`Renderer::draw`]
/// orders them. What they drew and HC did not keep is hidden behind what they drew or lies
/// outside the frustum, so the image is the PVS's. Returns the PVS's counts as [`rvg()`]
/// would draw it (gathered for this view already: copied), with the time of the draws made.
pub fn rvg_over(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    pvs: &[NodeId],
    begun: Begun,
    history: &mut ClusterHistory,
) -> Result<DrawStats, RenderError> {
    let opaque = if r.options().cluster_tests.occlusion {
        let pyramid = match begun.pyramid {
            Some(p) => p,
            None => r.depth_pyramid()?,
        };
        let drawn = |id: NodeId, k: usize, h: &ClusterHistory| {
            begun.hc.binary_search(&id).is_ok() || (begun.or.binary_search(&id).is_ok() && h.was_visible(id, k))
        };
        // The visible clusters drawn before count whole: the triangle tests ran where they were drawn.
        let (rest, before) = draw_rest(r, scene, view, pvs, &pyramid, drawn, history)?;
        r.give_back(pyramid);
        DrawStats { triangles: rest.triangles + before, ..rest }
    } else {
        if let Some(p) = begun.pyramid {
            r.give_back(p);
        }
        *history = ClusterHistory::default();
        let drawn = |id: &NodeId| begun.or.binary_search(id).is_ok() || begun.hc.binary_search(id).is_ok();
        let new: Vec<NodeId> = pvs.iter().copied().filter(|id| !drawn(id)).collect();
        let made = if new.is_empty() { DrawStats::default() } else { r.draw_opaque(scene, view, &new, Pass::Color, false)? };
        let counts = r.gather(scene, view, pvs, r.options().cluster_tests, None)?;
        DrawStats { draws: made.draws, gpu_ns: made.gpu_ns, ..counts }
    };
    Ok(opaque + r.draw_translucent(scene, view, pvs, Pass::Color, false)?)
}

/// The opaque clusters of `pvs` with occlusion culling, in two passes as in niagara: first
/// those that `history` says were visible in the last frame, then the rest that are visible
/// ([`draw_rest`], against the pyramid of what the first drew, read back; on lavapipe the
/// exact GPU box test per cluster took RVG from 43 to 63 ms, this one breaks even:
/// docs/measurements/2026-12-02-clusters.md). The translucent clusters are blended over both.
fn visible_clusters(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    pvs: &[NodeId],
    history: &mut ClusterHistory,
) -> Result<DrawStats, RenderError> {
    let tests = r.options().cluster_tests;
    let mut first = r.gather(scene, view, pvs, tests, Some(&mut |id, k, _| history.was_visible(id, k)))?;
    r.submit(view, Pass::Color, Layer::Opaque, true, &mut first)?;
    let pyramid = r.depth_pyramid()?;
    let (second, _) = draw_rest(r, scene, view, pvs, &pyramid, |id, k, h| h.was_visible(id, k), history)?;
    r.give_back(pyramid);
    // Both gathers count every cluster of the nodes; the triangle tests ran on what each drew.
    let clusters = ClusterStats {
        backface_culled: first.clusters.backface_culled + second.clusters.backface_culled,
        small_culled: first.clusters.small_culled + second.clusters.small_culled,
        ..second.clusters
    };
    let opaque = DrawStats { nodes: second.nodes, clusters, ..first + second };
    Ok(opaque + r.draw_translucent(scene, view, pvs, Pass::Color, false)?)
}

/// Every cluster of `pvs` that the cluster tests keep, its box tested against `pyramid` of
/// the depth drawn so far (boxes around the eye or across the near plane count as visible,
/// as in HC): those visible that are not `drawn` already (node, cluster index, the last
/// frame's history) are drawn over the image. Conservative: a cluster is skipped only when
/// geometry drawn this frame hides all of its box. `history` then holds this frame's visible
/// clusters. Returns the draw's counts and the triangles of the visible clusters drawn before.
fn draw_rest(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    pvs: &[NodeId],
    pyramid: &Pyramid,
    drawn: impl Fn(NodeId, usize, &ClusterHistory) -> bool,
    history: &mut ClusterHistory,
) -> Result<(DrawStats, u64), RenderError> {
    let vp = view.view_proj().as_dmat4();
    let (mut occluded, mut before) = (0, 0);
    let mut rest = r.gather(
        scene,
        view,
        pvs,
        r.options().cluster_tests,
        Some(&mut |id, k, c: &ClusterRecord| {
            let b = c.aabb();
            let drawn = drawn(id, k, history);
            if view.frustum.needs_no_test(&b) || visible_box(pyramid, &vp, view, &b, CLUSTER_FINER, 0) {
                history.mark(id, k);
                before += u64::from(drawn) * u64::from(c.index_count / 3);
                return !drawn;
            }
            occluded += u64::from(!drawn);
            false
        }),
    )?;
    r.submit(view, Pass::Color, Layer::Opaque, false, &mut rest)?;
    history.end_frame();
    rest.clusters.occlusion_culled = occluded;
    Ok((rest, before))
}
