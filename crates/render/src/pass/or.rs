//! OR, the occluder pass (occlusion switch sec. 4.6): the last visible set, re-selected for the
//! newest camera, drawn into the depth buffer that HC tests against.

use osw_cull::View;
use osw_cull::cluster::ClusterHistory;
use osw_cull::front::update_front;
use osw_gpu::draw::{Layer, Pass};
use osw_gpu::renderer::{DrawStats, RenderError, Renderer};
use osw_scene::{NodeId, SceneFile};

/// Draws the opaque clusters of `ids` re-selected for `view` at `tau` (the front update of
/// sec. 4.6) in `writes`: into the depth buffer (the switch's nodes), or into the image too
/// (prev: RVG then draws only what OR and HC did not, Yoon 2003 sec. 5.4); `clear` starts a
/// new one. OR draws the front of V(i-2), then HC's additions of frame i-1 as they arrive:
/// HC chose those for camera i-1, so they are re-selected too and every occluder is geometry
/// at tau for camera i (tau may also change between frames).
/// With `history`, only the clusters it says were visible in the last frame are drawn (Yoon
/// 2003 sec. 5.3.1). `front` is scratch space kept across frames.
pub fn or(
    r: &mut Renderer,
    scene: &SceneFile,
    view: &View,
    ids: &[NodeId],
    tau: f64,
    (writes, clear, history): (Pass, bool, Option<&ClusterHistory>),
    front: &mut Vec<NodeId>,
) -> Result<DrawStats, RenderError> {
    update_front(scene.nodes(), ids, view, tau, front);
    let Some(h) = history else { return r.draw_opaque(scene, view, front, writes, clear) };
    let mut drawn = r.gather(scene, view, front, r.options().cluster_tests, Some(&mut |id, k, _| h.was_visible(id, k)))?;
    r.submit(view, writes, Layer::Opaque, clear, &mut drawn)?;
    Ok(drawn)
}
