//! Temporal error: popping, what a change of detail between two frames shows on screen. Yoon
//! 2003 sec. 6.5 names it as static LODs' cost ("popping due to switching between different
//! LODs"); a view-dependent cut changes detail in smaller steps and should show less of it.
//!
//! Frame i's visible set is drawn twice with camera i: with its own selection, and with the
//! selection that camera i-1 makes of the same nodes (the front update of occlusion switch
//! sec. 4.6, [`update_front`], run for the earlier camera). The pixels where a channel of the
//! two differs by more than [`POPPING_ABOVE`] levels are the frame's popping. Both draw the
//! same surfaces, so what became visible or hidden between the frames does not count: only
//! the change of detail does.

use crate::compare::changed_pixels;
use osw_cull::View;
use osw_cull::front::update_front;
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{RenderError, Renderer};
use osw_scene::{NodeId, SceneFile};

/// A pixel pops when a channel changes by more than this many levels of 255.
pub const POPPING_ABOVE: u8 = 2;

/// The fraction of pixels that pop in the frame of `view` (drawing its cut at `tau`) whose
/// visible set is `visible` (LOD ids at `tau`), against the selection `previous` (the view of the frame before)
/// makes of the same nodes. `scratch` is kept across frames.
pub fn popping(
    r: &mut Renderer,
    scene: &SceneFile,
    previous: &View,
    view: &View,
    visible: &[NodeId],
    tau: f64,
    scratch: &mut Vec<NodeId>,
) -> Result<f64, RenderError> {
    r.draw(scene, view, visible, Pass::Color, Load::Clear)?;
    let own = r.read_color()?;
    update_front(scene.nodes(), visible, previous, tau, scratch);
    // A cluster hierarchy's cut for the earlier camera, drawn with this one.
    let earlier_cut = View { lod: previous.lod_at(tau), ..view.clone() };
    r.draw(scene, &earlier_cut, scratch, Pass::Color, Load::Clear)?;
    let earlier = r.read_color()?;
    Ok(changed_pixels(&own, &earlier, POPPING_ABOVE) as f64 / (own.len() / 4).max(1) as f64)
}
