//! The front update (occlusion switch sec. 4.6): last frame's visible set re-selected for a new
//! camera before it is drawn as occluders. Each visible LOD is one of:
//! - over-refined (its owner's parent also meets tau): replaced by the highest ancestor's HLOD
//!   that meets tau;
//! - under-refined (its error exceeds tau now): replaced by its owner's descendants, each at
//!   the coarsest LOD that meets tau;
//! - refined: kept, at the coarsest LOD of its owner that meets tau.
//!
//! The result is real scene geometry at tau, so drawing it as occluders stays conservative at
//! tau = 0 and within tau pixels above it.

use crate::view::View;
use osw_scene::error_metric::select_lod;
use osw_scene::{NodeId, NodeRecord};

/// Re-selects `visible` (LOD ids) for `view` at `tau`; writes the new set, sorted and without
/// duplicates, to `out`.
pub fn update_front(nodes: &[NodeRecord], visible: &[NodeId], view: &View, tau: f64, out: &mut Vec<NodeId>) {
    out.clear();
    let fits = |id: NodeId| select_lod(nodes, id, view.eye, view.focal_px, tau);
    let mut stack = Vec::new();
    for &lod in visible {
        // Up while the parent meets tau (over-refined).
        let mut owner = nodes[lod as usize].parent;
        loop {
            let p = nodes[owner as usize].parent;
            if p == u32::MAX || fits(p).is_none() {
                break;
            }
            owner = p;
        }
        // Down where the owner does not meet tau (under-refined).
        stack.push(owner);
        while let Some(n) = stack.pop() {
            match fits(n) {
                Some(l) => out.push(l),
                None => stack.extend(nodes[n as usize].children()),
            }
        }
    }
    out.sort_unstable();
    out.dedup();
}
