//! RVG, the pass that draws the visible set (occlusion switch sec. 4): shared by `prev` and
//! the display, so that the switch's frames are prev's.

use osw_cull::View;
use osw_cull::cluster::ClusterHistory;
use osw_gpu::draw::Pass;
use osw_gpu::renderer::{DrawStats, RenderError, Renderer};
use osw_scene::NodeId;

/// Draws `pvs` in colour. Where the frame was occlusion culled, its hidden clusters are culled
/// too, in two passes against the depth of the clusters visible last frame
/// ([`Renderer::draw_visible`]); a frame whose culling was skipped because it did not pay
/// (osw_cull::payoff) is drawn as vfc draws: the clusters' depth read-back and pyramid are
/// occlusion culling's cost as much as HC's tests are. `history` holds the last frame's visible
/// clusters; a frame drawn without the test leaves none, so that the next culled frame finds
/// its clusters in its second pass rather than trust a view several frames old.
pub fn rvg(r: &mut Renderer, view: &View, pvs: &[NodeId], culled: bool, history: &mut ClusterHistory) -> Result<DrawStats, RenderError> {
    if culled {
        return r.draw_visible(view, pvs, Pass::Color, history);
    }
    *history = ClusterHistory::default();
    r.draw(view, pvs, Pass::Color, true)
}
