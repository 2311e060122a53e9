//! Hierarchical stop-and-wait occlusion culling (paper 001 sec. 3.3), the `sw` baseline: the
//! hierarchy front to back; each node's box is tested alone and the traversal waits for the
//! answer; a visible node that meets tau is drawn into the occluder buffer at once, so later
//! (farther) tests see it. No coherence between frames.

use crate::distance_queue::DistanceQueue;
use crate::frustum::Containment;
use crate::hc::HcStats;
use crate::tester::Occluders;
use crate::view::View;
use osw_scene::error_metric::select_lod;
use osw_scene::{NodeId, NodeRecord};

/// Runs S&W for `view` at `tau`; appends the PVS to `pvs`.
pub fn stop_and_wait(nodes: &[NodeRecord], view: &View, tau: f64, occ: &mut dyn Occluders, pvs: &mut Vec<NodeId>) -> HcStats {
    let mut stats = HcStats::default();
    let mut queue = DistanceQueue::new();
    queue.push(nodes, view.eye, 0);
    let mut answer = Vec::with_capacity(1);
    while let Some(id) = queue.pop() {
        let b = nodes[id as usize].aabb();
        if view.frustum.classify(&b) == Containment::Outside {
            stats.frustum_culled += 1;
            continue;
        }
        let visible = if view.frustum.needs_no_test(&b) {
            stats.untested += 1;
            true
        } else {
            answer.clear();
            occ.test(view, &[id], &mut answer);
            stats.tests += 1;
            answer[0].visible
        };
        if !visible {
            stats.occlusion_culled += 1;
            continue;
        }
        match select_lod(nodes, id, view.eye, view.focal_px, tau) {
            Some(lod) => {
                occ.render(&[lod]);
                pvs.push(lod);
            }
            None => nodes[id as usize].children().for_each(|c| queue.push(nodes, view.eye, c)),
        }
    }
    stats
}
