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

/// Draws `pvs` over the image that OR and HC began (`drawn`, sorted): the opaque clusters of
/// the nodes they did not draw, then the translucent clusters of all, as [`Renderer::draw`]
/// orders them (Yoon 2003 sec. 5.4). What they drew and HC did not keep is hidden behind
/// what they drew or lies outside the frustum, so the image is the PVS's. Returns the PVS's
/// counts as [`rvg()`] would draw it (gathered for this view already: copied), with the time
/// of the draws made.
pub fn rvg_over(r: &mut Renderer, scene: &SceneFile, view: &View, pvs: &[NodeId], drawn: &[NodeId]) -> Result<DrawStats, RenderError> {
    let new: Vec<NodeId> = pvs.iter().copied().filter(|id| drawn.binary_search(id).is_err()).collect();
    let opaque = if new.is_empty() { DrawStats::default() } else { r.draw_opaque(scene, view, &new, Pass::Color, false)? };
    let counts = r.gather(scene, view, pvs, r.options().cluster_tests, None)?;
    Ok(DrawStats { draws: opaque.draws, gpu_ns: opaque.gpu_ns, ..counts } + r.draw_translucent(scene, view, pvs, Pass::Color, false)?)
}

/// The opaque clusters of `pvs` with occlusion culling, in two passes as in niagara: first
/// those that `history` says were visible in the last frame, then every cluster's box is
/// tested against the farthest-depth pyramid of what that drew (read back; on lavapipe the
/// exact GPU box test per cluster took RVG from 43 to 63 ms, this one breaks even:
/// docs/measurements/2026-12-02-clusters.md), and those visible and not yet drawn are drawn.
/// Conservative: a cluster is skipped only when geometry drawn this frame hides all of its
/// box. `history` then holds this frame's visible clusters. The translucent clusters are
/// blended over both.
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
    // Every cluster that passes the frustum and cone tests, its box tested against the
    // pyramid (boxes around the eye or across the near plane count as visible, as in HC).
    let pyramid = Pyramid::new(view.width, view.height, r.read_depth()?);
    let vp = view.view_proj().as_dmat4();
    let mut occluded = 0;
    let mut second = r.gather(
        scene,
        view,
        pvs,
        tests,
        Some(&mut |id, k, c: &ClusterRecord| {
            let b = c.aabb();
            let drawn = history.was_visible(id, k);
            if view.frustum.needs_no_test(&b) || visible_box(&pyramid, &vp, view, &b, CLUSTER_FINER, 0) {
                history.mark(id, k);
                return !drawn;
            }
            occluded += u64::from(!drawn);
            false
        }),
    )?;
    r.submit(view, Pass::Color, Layer::Opaque, false, &mut second)?;
    history.end_frame();
    // Both gathers count every cluster of the nodes; the triangle tests ran on what each drew.
    let both = first + second;
    let clusters = ClusterStats {
        occlusion_culled: occluded,
        backface_culled: both.clusters.backface_culled,
        small_culled: both.clusters.small_culled,
        ..second.clusters
    };
    let opaque = DrawStats { nodes: second.nodes, clusters, ..both };
    Ok(opaque + r.draw_translucent(scene, view, pvs, Pass::Color, false)?)
}
