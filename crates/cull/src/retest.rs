//! HC's second pass (two-phase occlusion culling, as zeux's niagara does it): the nodes HC
//! found visible that V(i-1) lacked had nothing drawn for them in OR's depth buffer, so where a
//! region came into view (a turn, a disocclusion, the first frame) every box in it passed.
//! Once those additions are drawn, their part of the hierarchy is tested again top down: a
//! region hidden as a whole behind nearer additions is culled at the node that holds it, not
//! box by box, so the tests follow what is visible rather than the region's size.
//!
//! Only nodes on a path from the root to an addition are visited; those above the rest of the
//! PVS (`kept`) are visible without a test, as in the first pass. An addition stays when its
//! node and every tested node above it pass: the same answer as testing its own box, for a
//! tester whose answers are consistent (a box is visible when one inside it is).

use crate::frustum::Containment;
use crate::hc::{HcStats, above, owner, test_round};
use crate::tester::VisibilityTester;
use crate::view::View;
use osw_scene::{NodeId, NodeRecord};
use std::collections::{HashMap, HashSet};

/// Tests the additions `added` (LOD and HLOD ids, drawn into the depth buffer) again through
/// their part of the hierarchy; appends those still visible to `out`.
pub fn retest_additions<E>(
    nodes: &[NodeRecord],
    view: &View,
    kept: &[NodeId],
    added: &[NodeId],
    tester: &mut dyn VisibilityTester<Error = E>,
    out: &mut Vec<NodeId>,
) -> Result<HcStats, E> {
    // The additions by the BVH node that owns them, and every node on a path to one.
    let mut owned: HashMap<NodeId, Vec<NodeId>> = HashMap::new();
    let mut path: HashSet<NodeId> = HashSet::new();
    for &lod in added {
        // Not a node of this scene: kept, as the first pass found it.
        let Some(o) = owner(nodes, lod) else {
            out.push(lod);
            continue;
        };
        owned.entry(o).or_default().push(lod);
        let mut up = o;
        while path.insert(up) {
            match nodes.get(up as usize).map(|n| n.parent) {
                Some(p) if (p as usize) < nodes.len() => up = p,
                _ => break,
            }
        }
    }
    let above = above(nodes, kept);
    let mut stats = HcStats::default();
    let (mut open, mut batch, mut answers) = (vec![0u32], Vec::new(), Vec::new());
    let visible = |id: NodeId, open: &mut Vec<NodeId>, out: &mut Vec<NodeId>| {
        out.extend(owned.get(&id).into_iter().flatten());
        open.extend(nodes[id as usize].children().filter(|c| path.contains(c)));
    };
    while !open.is_empty() {
        batch.clear();
        while let Some(id) = open.pop() {
            if !path.contains(&id) {
                continue;
            }
            let b = nodes[id as usize].aabb();
            match view.frustum.classify(&b) {
                Containment::Outside => stats.frustum_culled += 1,
                _ if view.frustum.needs_no_test(&b) || above.contains(&id) => {
                    stats.untested += 1;
                    visible(id, &mut open, out);
                }
                _ => batch.push(id),
            }
        }
        if batch.is_empty() {
            break;
        }
        test_round(tester, view, &mut batch, &mut answers, &mut stats)?;
        for (&id, vis) in batch.iter().zip(&answers) {
            if vis.visible {
                visible(id, &mut open, out);
            } else {
                stats.occlusion_culled += 1;
            }
        }
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hc::tests::{scene, view_from};
    use crate::tester::Visibility;
    use glam::DVec3;

    /// Visible: a fixed set of ids; records every batch.
    struct Fixed(Vec<NodeId>, Vec<Vec<NodeId>>);

    impl VisibilityTester for Fixed {
        type Error = std::convert::Infallible;

        fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error> {
            self.1.push(ids.to_vec());
            out.extend(ids.iter().map(|id| Visibility { visible: self.0.contains(id), pixels: None }));
            Ok(())
        }
    }

    fn facing_both_leaves() -> View {
        view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0))
    }

    #[test]
    fn a_hidden_region_is_culled_at_the_node_that_holds_it() {
        // Both leaves' level 0 added (the first frame); the root hidden: nothing stays, one test.
        let (n, mut t, mut out) = (scene(), Fixed(vec![], vec![]), Vec::new());
        let s = retest_additions(&n, &facing_both_leaves(), &[], &[4, 6], &mut t, &mut out).unwrap();
        assert_eq!((out, t.1, s.tests, s.occlusion_culled), (vec![], vec![vec![0]], 1, 1));
    }

    #[test]
    fn the_answer_is_the_additions_own_box_test_when_answers_are_consistent() {
        // Root and leaf 2 visible: 6 stays, 4 goes.
        let (n, mut t, mut out) = (scene(), Fixed(vec![0, 2], vec![]), Vec::new());
        let s = retest_additions(&n, &facing_both_leaves(), &[], &[4, 6], &mut t, &mut out).unwrap();
        assert_eq!(out, vec![6]);
        assert_eq!(t.1, vec![vec![0], vec![1, 2]]);
        assert_eq!(s.tests, 3);
        // With leaf 1's level 0 kept, the root is above it and not tested: only leaf 2 is.
        let (mut t, mut out) = (Fixed(vec![2], vec![]), Vec::new());
        retest_additions(&n, &facing_both_leaves(), &[4], &[6], &mut t, &mut out).unwrap();
        assert_eq!((out, t.1), (vec![6], vec![vec![2]]));
    }

    #[test]
    fn an_hlod_addition_stays_with_its_group() {
        let (n, mut t, mut out) = (scene(), Fixed(vec![0], vec![]), Vec::new());
        retest_additions(&n, &facing_both_leaves(), &[], &[3], &mut t, &mut out).unwrap();
        assert_eq!(out, vec![3]);
    }
}
