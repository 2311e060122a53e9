//! RVG, the pass that draws the visible set (occlusion switch sec. 4): shared by `prev` and
//! the display, so that the switch's frames are prev's.

use osw_cull::View;
use osw_cull::cluster::VisibleClusters;
use osw_gpu::draw::{Layer, Pass};
use osw_gpu::renderer::{DrawStats, RenderError, Renderer};
use osw_scene::{NodeId, SceneFile};

/// Draws `pvs` in colour. With `notes` (HC's of this frame, [`crate::pass::note_clusters`])
/// only the opaque clusters they take, the others counted as occlusion culled; then the
/// translucent clusters of all.
pub fn rvg(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    pvs: &[NodeId],
    notes: Option<&VisibleClusters>,
) -> Result<DrawStats, RenderError> {
    let Some(notes) = notes else { return r.draw(scene, view, pvs, Pass::Color, true) };
    let mut drawn = gather_noted(r, scene, view, pvs, notes)?;
    r.submit(view, Pass::Color, Layer::Opaque, true, &mut drawn)?;
    Ok(drawn + r.draw_translucent(scene, view, pvs, Pass::Color, false)?)
}

/// The opaque clusters of `pvs` that `notes` take gathered, the others counted as occlusion
/// culled.
fn gather_noted(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    pvs: &[NodeId],
    notes: &VisibleClusters,
) -> Result<DrawStats, RenderError> {
    let mut hidden = 0;
    let mut drawn = r.gather(
        scene,
        view,
        pvs,
        r.options().cluster_tests,
        Some(&mut |id, k| {
            let take = notes.takes(id, k);
            hidden += u64::from(!take);
            take
        }),
    )?;
    drawn.clusters.occlusion_culled = hidden;
    Ok(drawn)
}

/// What OR and HC drew into the image before RVG (Yoon 2003 sec. 5.4): OR's nodes (sorted),
/// of each the clusters `or_notes` took when there were notes, else whole; and HC's
/// additions (sorted), whole.
pub struct Begun<'a> {
    pub or: &'a [NodeId],
    pub or_notes: Option<&'a VisibleClusters>,
    pub hc: &'a [NodeId],
}

/// Draws `pvs` over the image that OR and HC began: the opaque clusters they did not draw, of
/// those with `notes` only the ones HC noted visible, then the translucent clusters of all, as
/// [`Renderer::draw`] orders them. What they drew and HC did not keep is hidden behind what
/// they drew or lies outside the frustum, so the image is the PVS's. Returns the PVS's counts
/// as [`rvg()`] would draw it, with the time of the draws made.
pub fn rvg_over(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    pvs: &[NodeId],
    begun: Begun,
    notes: Option<&VisibleClusters>,
) -> Result<DrawStats, RenderError> {
    let (hc, or) = (|id: NodeId| begun.hc.binary_search(&id).is_ok(), |id: NodeId| begun.or.binary_search(&id).is_ok());
    let drawn = |id: NodeId, k: usize| hc(id) || (or(id) && begun.or_notes.is_none_or(|n| n.takes(id, k)));
    let opaque = if notes.is_none() && begun.or_notes.is_none() {
        // Whole nodes on both sides.
        let new: Vec<NodeId> = pvs.iter().copied().filter(|&id| !hc(id) && !or(id)).collect();
        let made = if new.is_empty() { DrawStats::default() } else { r.draw_opaque(scene, view, &new, Pass::Color, false)? };
        let counts = r.gather(scene, view, pvs, r.options().cluster_tests, None)?;
        DrawStats { draws: made.draws, gpu_ns: made.gpu_ns, ..counts }
    } else {
        // The counts first, as rvg() gathers them: the clusters drawn before were drawn under
        // this view and tests, but gathered with other clusters of theirs.
        let counts = match notes {
            Some(notes) => gather_noted(r, scene, view, pvs, notes)?,
            None => r.gather(scene, view, pvs, r.options().cluster_tests, None)?,
        };
        let visible = |id: NodeId, k: usize| notes.is_none_or(|n| n.takes(id, k));
        let mut rest = r.gather(scene, view, pvs, r.options().cluster_tests, Some(&mut |id, k| visible(id, k) && !drawn(id, k)))?;
        r.submit(view, Pass::Color, Layer::Opaque, false, &mut rest)?;
        DrawStats { draws: rest.draws, gpu_ns: rest.gpu_ns, ..counts }
    };
    Ok(opaque + r.draw_translucent(scene, view, pvs, Pass::Color, false)?)
}
