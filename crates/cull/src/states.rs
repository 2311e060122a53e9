//! Nodes by culling state, as in the occlusion switch's colour plate: what a viewer sees at tau, each
//! node marked visible, frustum-culled or occlusion-culled for another (frozen) culling camera.
//! The display draws the three sets in three colours, so a person can fly out of the culling
//! camera's view and look at what HC kept and what it dropped.

use crate::frustum::{Containment, Frustum};
use osw_scene::{NodeId, NodeRecord};

/// The viewer's LOD nodes in three sets.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct States {
    /// HC found the node, or a coarser or finer node of the same subtree, visible.
    pub visible: Vec<NodeId>,
    /// Outside the culling camera's frustum.
    pub frustum_culled: Vec<NodeId>,
    /// Inside the frustum, not visible: hidden by occluders.
    pub occlusion_culled: Vec<NodeId>,
}

/// Classifies `front` (LOD ids the viewer draws, e.g. frustum culling's PVS for the viewer)
/// against `visible` (the culling camera's V, LOD ids) and the culling camera's `frustum`.
/// A front node counts as visible when its BVH owner, an ancestor of it or a descendant of it
/// owns a node of `visible`: the viewer and HC select LODs for different cameras, so the same
/// geometry can sit at different levels of the two cuts.
pub fn classify(nodes: &[NodeRecord], front: &[NodeId], visible: &[NodeId], frustum: &Frustum) -> States {
    const NONE: u32 = u32::MAX;
    // owns[b]: BVH node b owns a visible LOD; under[b]: a descendant of b does.
    let (mut owns, mut under) = (vec![false; nodes.len()], vec![false; nodes.len()]);
    for &v in visible {
        let owner = nodes[v as usize].parent;
        owns[owner as usize] = true;
        let mut p = nodes[owner as usize].parent;
        while p != NONE && !under[p as usize] {
            under[p as usize] = true;
            p = nodes[p as usize].parent;
        }
    }
    let mut out = States::default();
    for &f in front {
        let owner = nodes[f as usize].parent;
        let mut seen = owns[owner as usize] || under[owner as usize];
        let mut p = nodes[owner as usize].parent;
        while !seen && p != NONE {
            seen = owns[p as usize];
            p = nodes[p as usize].parent;
        }
        let set = if seen {
            &mut out.visible
        } else if frustum.classify(&nodes[f as usize].aabb()) == Containment::Outside {
            &mut out.frustum_culled
        } else {
            &mut out.occlusion_culled
        };
        set.push(f);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hc::tests::{scene, view_from};
    use glam::DVec3;

    // The test scene: root 0 (HLOD 3) over leaf 1 (x 0..1, LODs 4, 5) and leaf 2 (x 10..11,
    // LOD 6).

    #[test]
    fn same_lod_visible_other_hidden_or_outside() {
        let n = scene();
        // Culling camera looks at leaf 1 only (from -x, along +x... leaf 2 lies behind leaf 1
        // and is in the frustum): V = {4}.
        let culling = view_from(DVec3::new(-5.0, 0.5, 0.5), DVec3::new(0.5, 0.5, 0.5));
        let s = classify(&n, &[4, 6], &[4], &culling.frustum);
        assert_eq!(s, States { visible: vec![4], frustum_culled: vec![], occlusion_culled: vec![6] });
        // Looking away from both: leaf 2 is outside the frustum.
        let away = view_from(DVec3::new(-5.0, 0.5, 0.5), DVec3::new(-10.0, 0.5, 0.5));
        let s = classify(&n, &[4, 6], &[4], &away.frustum);
        assert_eq!(s.frustum_culled, vec![6]);
    }

    #[test]
    fn coarser_and_finer_cuts_of_one_subtree_count_as_visible() {
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        // HC took the root's HLOD 3: both leaves' levels are under it.
        assert_eq!(classify(&n, &[4, 6], &[3], &v.frustum).visible, vec![4, 6]);
        // HC took leaf 1's level 5 while the viewer draws the root HLOD: visible.
        assert_eq!(classify(&n, &[3], &[5], &v.frustum).visible, vec![3]);
        // Nothing visible: everything in the frustum is occlusion-culled.
        assert_eq!(classify(&n, &[4, 6], &[], &v.frustum).occlusion_culled, vec![4, 6]);
    }
}
