//! RVG, the pass that draws the visible set (occlusion switch sec. 4): shared by `prev` and
//! the display, so that the switch's frames are prev's.

use osw_cull::View;
use osw_cull::cluster::VisibleClusters;
use osw_gpu::draw::{Layer, Load, Pass};
use osw_gpu::renderer::{DrawStats, RenderError, Renderer};
use osw_scene::{NodeId, SceneFile};

/// Draws `pvs` in colour: `pass` is [`Pass::Color`] on a cleared buffer (the display), or
/// [`Pass::ColorOver`] over the depth that prev's OR and HC left, which makes the same image.
/// With `notes` (HC's of this frame, [`crate::pass::note_clusters`]) only the opaque clusters
/// they take, the others counted as occlusion culled; then the translucent clusters of all.
pub fn rvg(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    pvs: &[NodeId],
    notes: Option<&VisibleClusters>,
    pass: Pass,
) -> Result<DrawStats, RenderError> {
    let Some(notes) = notes else { return r.draw(scene, view, pvs, pass, Load::Clear) };
    let mut drawn = gather_noted(r, scene, view, pvs, notes)?;
    r.submit(view, pass, Layer::Opaque, Load::Clear, &mut drawn)?;
    Ok(drawn + r.draw_translucent(scene, view, pvs, pass, Load::Keep)?)
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
        false,
        Some(&mut |id, k| {
            let take = notes.takes(id, k);
            hidden += u64::from(!take);
            take
        }),
    )?;
    drawn.clusters.occlusion_culled = hidden;
    Ok(drawn)
}
