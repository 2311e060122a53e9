//! The front update (occlusion switch sec. 4.6): last frame's visible set re-selected for a new
//! camera before it is drawn as occluders. Each visible LOD is one of:
//! - over-refined (its owner's parent also meets tau): replaced by the highest ancestor's HLOD
//!   that meets tau;
//! - under-refined (its error exceeds tau now): replaced by its owner's descendants, each at
//!   the coarsest LOD that meets tau;
//! - refined: kept, at the coarsest LOD of its owner that meets tau.
//!
//! In a cluster hierarchy a node can be drawn and refined at once (its coarse groups and its
//! children's finer ones); a visible cut node is kept while its node still draws one, and its
//! node's children that were visible are in the set themselves.
//!
//! The result is real scene geometry at tau, so drawing it as occluders stays conservative at
//! tau = 0 and within tau pixels above it.

use crate::view::View;
use osw_scene::error_metric::select;
use osw_scene::{NodeId, NodeRecord};

/// Re-selects `visible` (LOD ids) for `view` at `tau`; writes the new set, sorted and without
/// duplicates, to `out`.
pub fn update_front(nodes: &[NodeRecord], visible: &[NodeId], view: &View, tau: f64, out: &mut Vec<NodeId>) {
    out.clear();
    let lod = view.lod_at(tau);
    let mut stack = Vec::new();
    for &l in visible {
        // Up while the parent needs none of its children (over-refined).
        let mut owner = nodes[l as usize].parent;
        loop {
            let p = nodes[owner as usize].parent;
            if p == u32::MAX || select(nodes, p, &lod).refine {
                break;
            }
            owner = p;
        }
        // Down where the owner draws nothing (under-refined).
        stack.push(owner);
        while let Some(n) = stack.pop() {
            let s = select(nodes, n, &lod);
            match s.draw {
                Some(l) => out.push(l),
                None if s.refine => stack.extend(nodes[n as usize].children()),
                None => {}
            }
        }
    }
    out.sort_unstable();
    out.dedup();
}
