//! The hardware cull (HC): occlusion switch alg. 4.1, breadth first with one batch of occlusion tests
//! per round (sec. 4.7.1), LOD selection by projected error against tau (sec. 4.1) and the
//! pixel-count stop (sec. 4.7.2).
//!
//! Each round: drop boxes outside the frustum; boxes that contain the eye or cross the near
//! plane are visible without a test, and so are, from the previous frame, the BVH nodes above
//! its visible set that must still be refined (below); test the rest as one batch. A visible node whose coarsest fitting
//! LOD or HLOD meets tau goes into the PVS; otherwise its children join the round (untested
//! parent) or form the next one (tested parent). A visible group whose box shows fewer than tau
//! pixels stops at its HLOD: its error cannot show in more pixels than are visible (sec. 4.7.2).
//!
//! Coherence (sec. 4.6, and CHC's pull-up): the nodes above V(i-1) were
//! visible last frame and nearly always still are; testing them again is what made a frame's
//! tests follow the scene's depth rather than what is visible. Taking them as visible is
//! conservative (their children are still tested), LOD selection still starts at the root
//! (one whose LOD meets tau is tested first), and a node whose subtree left V(i-1) is tested
//! again, so an occluded region is culled as high as it can be. The tests are then the front: V(i-1)'s nodes, their occluded siblings
//! and what came into view, in about one round.
//!
//! What came into view has no occluder in OR's depth buffer (drawn from V(i-1)), so every box
//! in it passes and the traversal would go down to its LOD cut box by box. After each round
//! the tester is offered the PVS's new LODs as occluders for the next rounds, as CHC (paper
//! 001) draws what it finds while it traverses.

use crate::frustum::Containment;
use crate::tester::VisibilityTester;
use crate::view::{Cut, View};
use osw_scene::error_metric::{Selection, select};
use osw_scene::format::NodeKind;
use osw_scene::{NodeId, NodeRecord};
use std::collections::HashSet;

/// Counts of one traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HcStats {
    /// Rounds (batches) of tests.
    pub levels: u32,
    /// Boxes sent to the tester.
    pub tests: u32,
    /// Of `tests`, those made again after the traversal (osw_render's `hc_pass`: the second
    /// look at small boxes and the exact test of additions drawn as occluders).
    pub retests: u32,
    /// Boxes accepted without a test (eye inside, crossing the near plane, above V(i-1)).
    pub untested: u32,
    pub frustum_culled: u32,
    pub occlusion_culled: u32,
    /// Triangles of the nodes occlusion culled (a BVH node's at full detail): what culling
    /// kept from RVG, for judging whether it pays (crate::payoff).
    pub culled_triangles: u64,
    /// Groups that stopped at their HLOD because few of their pixels are visible.
    pub pixel_stops: u32,
    /// Boxes seen but counted as occluded by adaptive culling (Bartz 1999 eq. 1).
    pub adaptive_culled: u32,
    /// Boxes taken as visible untested because the culling budget was spent (Bartz 1999 eq. 2).
    pub over_budget: u32,
    /// The traversal's tests by where they fall, summing to `tests - retests`: nodes of V(i-1)
    /// (owners of its LODs, and nodes above it whose LOD now meets tau), their siblings off
    /// the paths to V(i-1) (occluded, or coming into view), and nodes inside what this frame
    /// found visible anew (from the root, every test).
    pub tests_front: u32,
    pub tests_siblings: u32,
    pub tests_new: u32,
}

/// Runs HC from the root for `view` at `tau` pixels of error, testing every box in the
/// frustum above the LOD cut. Appends the PVS (LOD and HLOD node ids, in the order found) to
/// `pvs`.
pub fn hardware_cull<E>(
    nodes: &[NodeRecord],
    view: &View,
    tau: f64,
    tester: &mut dyn VisibilityTester<Error = E>,
    pvs: &mut Vec<NodeId>,
) -> Result<HcStats, E> {
    traverse(Cut { nodes, view, tau }, &[], &Coherence::default(), tester, pvs, &mut Vec::new())
}

/// What V(i-1) says of the hierarchy: the BVH nodes above it, taken as visible untested, and
/// the nodes owning its LODs.
#[derive(Default)]
struct Coherence {
    above: HashSet<NodeId>,
    owners: HashSet<NodeId>,
}

/// [`hardware_cull`] against the frustum alone (vfc, and a frame whose occlusion culling does
/// not pay): LODs at tau of every node in view.
pub fn frustum_cull(nodes: &[NodeRecord], view: &View, tau: f64, pvs: &mut Vec<NodeId>) -> HcStats {
    let Ok(stats) = hardware_cull(nodes, view, tau, &mut crate::tester::AllVisible, pvs);
    stats
}

/// The LODs that the frustum holds at `tau`, nearest the eye first (by their boxes), up to
/// `budget` triangles (at least the nearest one); sorted by id. HC's first occluders where
/// there is no V(i-1): any geometry of the frame's LODs is a conservative occluder (what it
/// hides, whatever hides it hides too).
pub fn nearest_in_view(nodes: &[NodeRecord], view: &View, tau: f64, budget: u64) -> Vec<NodeId> {
    let mut ids = Vec::new();
    frustum_cull(nodes, view, tau, &mut ids);
    let distance = |id: NodeId| {
        let b = nodes[id as usize].aabb();
        (b.min.as_dvec3() - view.eye).max(view.eye - b.max.as_dvec3()).max(glam::DVec3::ZERO).length_squared()
    };
    let mut by_distance: Vec<(f64, NodeId)> = ids.iter().map(|&id| (distance(id), id)).collect();
    by_distance.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut triangles = 0;
    let mut nearest: Vec<NodeId> = by_distance
        .into_iter()
        .take_while(|&(_, id)| {
            let under = triangles < budget;
            triangles += nodes[id as usize].triangles;
            under
        })
        .map(|(_, id)| id)
        .collect();
    nearest.sort_unstable();
    nearest
}

/// HC as [`hardware_cull`], taking the BVH nodes above `previous` (V(i-1): LOD and HLOD ids,
/// sorted) as visible without a test. Same PVS for a tester whose answers are consistent (a
/// box is visible when one inside it is) and that takes no occluders, fewer tests the more
/// coherent the frames.
pub fn hardware_cull_from<E>(
    nodes: &[NodeRecord],
    view: &View,
    tau: f64,
    previous: &[NodeId],
    tester: &mut dyn VisibilityTester<Error = E>,
    pvs: &mut Vec<NodeId>,
) -> Result<HcStats, E> {
    hardware_cull_seen(nodes, view, tau, previous, &mut Vec::new(), tester, pvs)
}

/// [`hardware_cull_from`], also taking the BVH nodes in `seen` (and those above them) as
/// visible without a test, and leaving in `seen` the nodes this traversal's tests found
/// visible.
///
/// CHC's visible interior nodes: a node found visible whose subtree V(i-1) holds no LOD of
/// (a region that passes the box tests but whose geometry the retest finds hidden) would be
/// tested again from its highest node every frame, a chain of tests down to the nodes that
/// are hidden; CHC opens such a node untested the next frame and tests its children. As
/// in CHC, a node opened untested and none of whose children is found visible is not in
/// `seen` afterwards: it is tested the frame after. `seen` may be several frames old (the
/// switch's HC node has its own from two frames back): any set of nodes is conservative
/// (a node whose LOD meets tau is still tested before its LOD joins the PVS).
pub fn hardware_cull_seen<E>(
    nodes: &[NodeRecord],
    view: &View,
    tau: f64,
    previous: &[NodeId],
    seen: &mut Vec<NodeId>,
    tester: &mut dyn VisibilityTester<Error = E>,
    pvs: &mut Vec<NodeId>,
) -> Result<HcStats, E> {
    let owners = previous.iter().filter_map(|&id| owner(nodes, id)).collect();
    let mut above = above(nodes, previous);
    for &id in seen.iter() {
        insert_with_ancestors(nodes, id, &mut above);
    }
    seen.clear();
    traverse(Cut { nodes, view, tau }, previous, &Coherence { above, owners }, tester, pvs, seen)
}

/// The BVH node that owns LOD or HLOD `id`: a leaf for its LODs, a group for its HLOD.
pub(crate) fn owner(nodes: &[NodeRecord], id: NodeId) -> Option<NodeId> {
    let n = nodes.get(id as usize)?;
    Some(if n.kind() == NodeKind::Lod { n.parent } else { id })
}

/// The proper BVH ancestors of the nodes owning the LODs `ids`: O(nodes visited), each chain
/// stops where it meets one already walked.
pub(crate) fn above(nodes: &[NodeRecord], ids: &[NodeId]) -> HashSet<NodeId> {
    let mut set = HashSet::new();
    for &id in ids {
        if let Some(o) = owner(nodes, id).and_then(|o| nodes.get(o as usize)) {
            insert_with_ancestors(nodes, o.parent, &mut set);
        }
    }
    set
}

/// Inserts node `id` and its ancestors into `set`, up to the first already in it (none for
/// an id outside the table, such as the root's parent).
fn insert_with_ancestors(nodes: &[NodeRecord], mut id: NodeId, set: &mut HashSet<NodeId>) {
    while let Some(n) = nodes.get(id as usize) {
        if !set.insert(id) {
            break;
        }
        id = n.parent;
    }
}

/// The traversal; `seen` gets the nodes its tests found visible.
fn traverse<E>(
    cut: Cut,
    previous: &[NodeId],
    coherence: &Coherence,
    tester: &mut dyn VisibilityTester<Error = E>,
    pvs: &mut Vec<NodeId>,
    seen: &mut Vec<NodeId>,
) -> Result<HcStats, E> {
    let Cut { nodes, view, tau } = cut;
    let above = &coherence.above;
    let mut stats = HcStats::default();
    let (mut open, mut batch, mut answers) = (vec![0u32], Vec::new(), Vec::new());
    // The PVS's LODs not in V(i-1) found since the tester last took some, and where this
    // round's start in `pvs`.
    let (mut new, mut new_from) = (Vec::new(), pvs.len());
    while !open.is_empty() {
        batch.clear();
        while let Some(id) = open.pop() {
            let b = nodes[id as usize].aabb();
            match view.frustum.classify(&b) {
                Containment::Outside => stats.frustum_culled += 1,
                _ if view.frustum.needs_no_test(&b) => {
                    stats.untested += 1;
                    refine(cut, id, None, &mut stats, pvs, &mut open);
                }
                // Above V(i-1) and still to be refined; one whose LOD now meets tau is tested,
                // as it would be from the root, before its LOD joins the PVS.
                _ if above.contains(&id) && select(nodes, id, &view.lod_at(tau)) == (Selection { draw: None, refine: true }) => {
                    stats.untested += 1;
                    open.extend(nodes[id as usize].children());
                }
                _ => {
                    let parent = nodes[id as usize].parent;
                    let place = if above.contains(&id) || coherence.owners.contains(&id) {
                        &mut stats.tests_front
                    } else if above.contains(&parent) {
                        &mut stats.tests_siblings
                    } else {
                        &mut stats.tests_new
                    };
                    *place += u32::from(tester.tests());
                    batch.push(id);
                }
            }
        }
        if batch.is_empty() {
            break;
        }
        test_round(tester, view, &mut batch, &mut answers, &mut stats)?;
        for (&id, vis) in batch.iter().zip(&answers) {
            if vis.visible {
                seen.push(id);
                refine(cut, id, vis.pixels, &mut stats, pvs, &mut open);
            } else {
                stats.occlusion_culled += 1;
                stats.culled_triangles += nodes[id as usize].triangles;
            }
        }
        // Occluders where OR drew none (a region came into view): the PVS's new LODs, for
        // the rounds still to come.
        if !previous.is_empty() {
            new.extend(pvs[new_from..].iter().copied().filter(|id| previous.binary_search(id).is_err()));
            new_from = pvs.len();
            if !new.is_empty() && !open.is_empty() && tester.add_occluders(view, &new)? {
                new.clear();
            }
        }
    }
    Ok(stats)
}

/// One round of tests (sec. 4.7.1: a batch per round trip): sorts `batch` and answers it into
/// `answers`, counting the round and its tests.
pub(crate) fn test_round<E>(
    tester: &mut dyn VisibilityTester<Error = E>,
    view: &View,
    batch: &mut [NodeId],
    answers: &mut Vec<crate::tester::Visibility>,
    stats: &mut HcStats,
) -> Result<(), E> {
    batch.sort_unstable();
    stats.levels += 1;
    answers.clear();
    tester.test(view, batch, answers)?;
    assert_eq!(answers.len(), batch.len(), "tester must answer every box");
    if tester.tests() {
        stats.tests += batch.len() as u32;
    }
    Ok(())
}

/// A visible BVH node: its LOD into the PVS, its HLOD when few of its `pixels` show, or its
/// children into `open` (with its cut node, in a cluster hierarchy).
fn refine(cut: Cut, id: NodeId, pixels: Option<u32>, stats: &mut HcStats, pvs: &mut Vec<NodeId>, open: &mut Vec<NodeId>) {
    let Cut { nodes, view, tau } = cut;
    let n = &nodes[id as usize];
    let coarsest = n.lods().last().filter(|&l| !nodes[l as usize].is_cut());
    let s = select(nodes, id, &view.lod_at(tau));
    if let (true, Some(px), Some(hlod)) = (s.refine, pixels, coarsest)
        && (px as f64) < tau
    {
        stats.pixel_stops += 1;
        pvs.push(hlod);
        return;
    }
    pvs.extend(s.draw);
    if s.refine {
        open.extend(n.children());
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::tester::{AllVisible, Visibility};
    use glam::DVec3;
    use osw_scene::Camera;

    /// A node of a hand-built scene: a box spanning x in [x0, x1] and y, z in [0, 1], its
    /// parent, its children and its LODs (first, count), error 0.
    fn record(kind: NodeKind, x0: f32, x1: f32, parent: u32, children: (u32, u32), lods: (u32, u32)) -> NodeRecord {
        NodeRecord {
            bbox_min: [x0, 0.0, 0.0],
            bbox_max: [x1, 1.0, 1.0],
            kind: kind as u32,
            parent,
            first_child: children.0,
            child_count: children.1,
            first_lod: lods.0,
            lod_count: lods.1,
            ..bytemuck::Zeroable::zeroed()
        }
    }

    /// A hand-built scene: root group 0 over leaves 1 (x in [0,1]) and 2 (x in [10,11]);
    /// node 3 is the root's HLOD (error 0.5); 4 and 5 are leaf 1's levels 0 and 1 (error 0.1);
    /// 6 is leaf 2's level 0. All boxes span y, z in [0, 1].
    pub(crate) fn scene() -> Vec<NodeRecord> {
        let node = |kind, x0, x1, error, parent, children, lods| NodeRecord { error, ..record(kind, x0, x1, parent, children, lods) };
        vec![
            node(NodeKind::Group, 0.0, 11.0, 0.5, u32::MAX, (1, 2), (3, 1)),
            node(NodeKind::Leaf, 0.0, 1.0, 0.0, 0, (0, 0), (4, 2)),
            node(NodeKind::Leaf, 10.0, 11.0, 0.0, 0, (0, 0), (6, 1)),
            node(NodeKind::Lod, 0.0, 11.0, 0.5, 0, (0, 0), (0, 0)),
            node(NodeKind::Lod, 0.0, 1.0, 0.0, 1, (0, 0), (0, 0)),
            node(NodeKind::Lod, 0.0, 1.0, 0.1, 1, (0, 0), (0, 0)),
            node(NodeKind::Lod, 10.0, 11.0, 0.0, 2, (0, 0), (0, 0)),
        ]
    }

    /// A deeper scene: root group 0 over leaf 1 and group 2; group 2 over leaf 3 and group 4;
    /// group 4 over leaf 5 and group 6; group 6 over leaves 11 and 12. Leaves' level 0: 7
    /// (leaf 1), 8 (3), 9 (5), 13 (11), 14 (12); node 10 is unused. Boxes along x, 10 apart.
    fn deep_scene() -> Vec<NodeRecord> {
        let node = record;
        let (g, l, lod) = (NodeKind::Group, NodeKind::Leaf, NodeKind::Lod);
        vec![
            node(g, 0.0, 41.0, u32::MAX, (1, 2), (0, 0)),
            node(l, 0.0, 1.0, 0, (0, 0), (7, 1)),
            node(g, 10.0, 41.0, 0, (3, 2), (0, 0)),
            node(l, 10.0, 11.0, 2, (0, 0), (8, 1)),
            node(g, 20.0, 41.0, 2, (5, 2), (0, 0)),
            node(l, 20.0, 21.0, 4, (0, 0), (9, 1)),
            node(g, 30.0, 41.0, 4, (11, 2), (0, 0)),
            node(lod, 0.0, 1.0, 1, (0, 0), (0, 0)),
            node(lod, 10.0, 11.0, 3, (0, 0), (0, 0)),
            node(lod, 20.0, 21.0, 5, (0, 0), (0, 0)),
            node(lod, 0.0, 0.0, 0, (0, 0), (0, 0)),
            node(l, 30.0, 31.0, 6, (0, 0), (13, 1)),
            node(l, 40.0, 41.0, 6, (0, 0), (14, 1)),
            node(lod, 30.0, 31.0, 11, (0, 0), (0, 0)),
            node(lod, 40.0, 41.0, 12, (0, 0), (0, 0)),
        ]
    }

    #[test]
    fn the_first_occluders_are_the_nearest_lods_in_view_up_to_the_budget() {
        // Leaves' level 0 at x 0, 10, 20, 30, 40 (deep_scene), 100 triangles each; the eye
        // looks down +x from x -5, then from x 45 back down -x.
        let mut nodes = deep_scene();
        for n in nodes.iter_mut().filter(|n| n.kind() == NodeKind::Lod) {
            n.triangles = 100;
        }
        let from_low = view_from(DVec3::new(-5.0, 0.5, 0.5), DVec3::new(50.0, 0.5, 0.5));
        assert_eq!(nearest_in_view(&nodes, &from_low, 0.0, 150), vec![7, 8], "the budget is passed by the last taken");
        assert_eq!(nearest_in_view(&nodes, &from_low, 0.0, 1), vec![7], "at least the nearest");
        let from_high = view_from(DVec3::new(45.0, 0.5, 0.5), DVec3::new(-50.0, 0.5, 0.5));
        assert_eq!(nearest_in_view(&nodes, &from_high, 0.0, 300), vec![9, 13, 14], "nearest first, sorted by id");
        assert_eq!(nearest_in_view(&nodes, &from_high, 0.0, u64::MAX).len(), 5, "everything in view");
        let away = view_from(DVec3::new(-5.0, 0.5, 0.5), DVec3::new(-50.0, 0.5, 0.5));
        assert!(nearest_in_view(&nodes, &away, 0.0, 150).is_empty(), "nothing in view");
    }

    pub(crate) fn view_from(eye: DVec3, target: DVec3) -> View {
        View::new(&Camera::look_at(eye, target, 60.0), DVec3::ZERO, 100, 100, 0.01)
    }

    /// Answers from a fixed set of visible ids, counting batches.
    struct Fixed {
        visible: Vec<NodeId>,
        pixels: Option<u32>,
        batches: Vec<Vec<NodeId>>,
    }

    impl VisibilityTester for Fixed {
        type Error = std::convert::Infallible;

        fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error> {
            self.batches.push(ids.to_vec());
            out.extend(ids.iter().map(|id| Visibility { visible: self.visible.contains(id), pixels: self.pixels }));
            Ok(())
        }
    }

    /// Every box visible; records the occluders offered, taking them from the `take`-th offer.
    #[derive(Default)]
    struct Offered(Vec<Vec<NodeId>>, usize);

    impl VisibilityTester for Offered {
        type Error = std::convert::Infallible;

        fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error> {
            out.extend(ids.iter().map(|_| Visibility { visible: true, pixels: None }));
            Ok(())
        }

        fn add_occluders(&mut self, _: &View, lods: &[NodeId]) -> Result<bool, Self::Error> {
            self.0.push(lods.to_vec());
            Ok(self.0.len() > self.1)
        }
    }

    #[test]
    fn the_new_lods_are_offered_as_occluders_and_the_old_ones_not() {
        // Leaf 8's level 0 was visible (V(i-1)): round 1 finds 7 (new) and 8, round 2 finds 9,
        // round 3 finds 13 and 14, after which nothing is left to test and nothing is offered.
        let (deep, mut pvs) = (deep_scene(), Vec::new());
        let wide = view_from(DVec3::new(20.5, 0.5, 80.0), DVec3::new(20.5, 0.5, 0.0));
        let mut t = Offered(Vec::new(), 0);
        hardware_cull_from(&deep, &wide, 0.0, &[8], &mut t, &mut pvs).unwrap();
        pvs.sort();
        assert_eq!((pvs, t.0), (vec![7, 8, 9, 13, 14], vec![vec![7], vec![9]]));
        // A tester that declines is offered the same LODs again with the next round's.
        let mut t = Offered(Vec::new(), 1);
        hardware_cull_from(&deep, &wide, 0.0, &[8], &mut t, &mut Vec::new()).unwrap();
        assert_eq!(t.0, vec![vec![7], vec![7, 9]]);
        let (n, v) = (scene(), view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0)));
        // Without V(i-1), OR drew nothing and the whole PVS is new: nothing is offered.
        let (mut t, mut pvs) = (Offered::default(), Vec::new());
        hardware_cull(&n, &v, 0.0, &mut t, &mut pvs).unwrap();
        assert!(t.0.is_empty());
    }

    #[test]
    fn tau_zero_draws_every_leaf_at_full_detail() {
        // Expected PVS: level 0 of both leaves, {4, 6}.
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let mut pvs = Vec::new();
        let s = hardware_cull(&n, &v, 0.0, &mut AllVisible, &mut pvs).unwrap();
        pvs.sort();
        assert_eq!(pvs, vec![4, 6]);
        assert_eq!(s.levels, 2);
        assert_eq!(s.tests, 0, "frustum culling issues no occlusion test");
    }

    #[test]
    fn far_away_the_root_hlod_is_enough() {
        // 0.5 units of error 1e4 units away: 0.5 * 86.6 / 1e4 px, far below tau = 1.
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 1e4), DVec3::new(5.5, 0.5, 0.0));
        let mut pvs = Vec::new();
        hardware_cull(&n, &v, 1.0, &mut AllVisible, &mut pvs).unwrap();
        assert_eq!(pvs, vec![3]);
    }

    #[test]
    fn occluded_leaf_is_culled_and_levels_are_batched() {
        // Only leaf 2 and the root visible: PVS = {6}; batches = [[0], [1, 2]].
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let mut t = Fixed { visible: vec![0, 2], pixels: None, batches: Vec::new() };
        let mut pvs = Vec::new();
        let s = hardware_cull(&n, &v, 0.0, &mut t, &mut pvs).unwrap();
        assert_eq!(pvs, vec![6]);
        assert_eq!(t.batches, vec![vec![0], vec![1, 2]]);
        assert_eq!(s.occlusion_culled, 1);
    }

    #[test]
    fn behind_the_camera_is_frustum_culled_and_near_boxes_are_not_tested() {
        let n = scene();
        // Eye inside leaf 1's box looking away from leaf 2: root and leaf 1 need no test,
        // leaf 2 (x = 10..11) is behind.
        let v = view_from(DVec3::new(0.5, 0.5, 0.5), DVec3::new(-5.0, 0.5, 0.5));
        let mut t = Fixed { visible: vec![], pixels: None, batches: Vec::new() };
        let mut pvs = Vec::new();
        let s = hardware_cull(&n, &v, 0.0, &mut t, &mut pvs).unwrap();
        assert_eq!(pvs, vec![4]);
        assert_eq!(s.frustum_culled, 1);
        assert_eq!(s.untested, 2);
        assert!(t.batches.is_empty());
    }

    #[test]
    fn nodes_above_the_previous_visible_set_are_not_tested() {
        // V(i-1) = {6} (leaf 2's level 0): the root is above it and taken as visible; both
        // leaves are tested in the first round, leaf 1 is found occluded.
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let mut t = Fixed { visible: vec![2], pixels: None, batches: Vec::new() };
        let mut pvs = Vec::new();
        let s = hardware_cull_from(&n, &v, 0.0, &[6], &mut t, &mut pvs).unwrap();
        assert_eq!(pvs, vec![6]);
        assert_eq!(t.batches, vec![vec![1, 2]]);
        assert_eq!((s.tests, s.untested, s.occlusion_culled), (2, 1, 1));
        // Nothing of V(i-1) under the root (its HLOD 3): the root is tested again, and culled.
        let mut t = Fixed { visible: vec![], pixels: None, batches: Vec::new() };
        pvs.clear();
        hardware_cull_from(&n, &v, 0.0, &[3], &mut t, &mut pvs).unwrap();
        assert!(pvs.is_empty());
        assert_eq!(t.batches, vec![vec![0]]);
    }

    #[test]
    fn few_visible_pixels_stop_at_the_hlod() {
        // From 30 units the root's HLOD shows 0.5 * 86.6 / 29 = 1.5 px of error > tau = 1, but
        // the tester counts fewer visible pixels (0) than tau: stop at the HLOD.
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let mut t = Fixed { visible: vec![0, 1, 2], pixels: Some(0), batches: Vec::new() };
        let mut pvs = Vec::new();
        let s = hardware_cull(&n, &v, 1.0, &mut t, &mut pvs).unwrap();
        assert_eq!(pvs, vec![3]);
        assert_eq!(s.pixel_stops, 1);
    }

    /// Visible where a chosen set of leaves is: a box is visible when a leaf inside it is, the
    /// consistency a conservative tester has on nested boxes. `marked`: those leaves and every
    /// BVH node above them.
    struct Leaves {
        marked: HashSet<NodeId>,
    }

    impl VisibilityTester for Leaves {
        type Error = std::convert::Infallible;

        fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error> {
            out.extend(ids.iter().map(|id| Visibility { visible: self.marked.contains(id), pixels: None }));
            Ok(())
        }
    }

    fn plant() -> &'static [NodeRecord] {
        use osw_scene::build::{BuildOptions, node_table};
        use osw_scene::generators::{GenKind, generate};
        static NODES: std::sync::OnceLock<Vec<NodeRecord>> = std::sync::OnceLock::new();
        NODES.get_or_init(|| {
            let objects = generate(GenKind::Plant, 40_000, 3).objects;
            node_table(objects, &BuildOptions::default()).expect("plant")
        })
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        /// Starting from any V(i-1), even one of another camera, HC finds the PVS the traversal
        /// from the root finds, at any tau; from its own V(i-1) it tests no more boxes.
        #[test]
        fn the_previous_visible_set_changes_the_tests_not_the_pvs(
            eyes in proptest::array::uniform2(proptest::array::uniform3(0.0f64..1.0)),
            dirs in proptest::array::uniform2(proptest::array::uniform3(-1.0f64..1.0)),
            tau in proptest::sample::select(vec![0.0, 1.0, 5.0, 50.0]),
            seed in 0u64..1_000,
            share in 1u64..8,
        ) {
            let nodes = plant();
            let root = nodes[0].aabb();
            let view_of = |k: usize| {
                let eye = root.min.as_dvec3() + DVec3::from(eyes[k]) * root.extent().as_dvec3();
                let dir = DVec3::from(dirs[k]).try_normalize().unwrap_or(DVec3::X);
                View::new(&Camera::look_along(eye, dir, 60.0), DVec3::ZERO, 256, 256, 0.01)
            };
            // About one leaf in `share` visible, chosen by a hash of its id.
            let mut marked = HashSet::new();
            for (id, n) in nodes.iter().enumerate() {
                if n.kind() == NodeKind::Leaf && (id as u64 ^ seed).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 61 < 8 / share {
                    let mut up = id as u32;
                    while (up as usize) < nodes.len() && marked.insert(up) {
                        up = nodes[up as usize].parent;
                    }
                }
            }
            let mut t = Leaves { marked };
            let (other, this) = (view_of(0), view_of(1));
            let mut previous = Vec::new();
            hardware_cull(nodes, &other, tau, &mut t, &mut previous).unwrap();
            let (mut want, mut got, mut again) = (Vec::new(), Vec::new(), Vec::new());
            let root_stats = hardware_cull(nodes, &this, tau, &mut t, &mut want).unwrap();
            hardware_cull_from(nodes, &this, tau, &previous, &mut t, &mut got).unwrap();
            let coherent = hardware_cull_from(nodes, &this, tau, &want, &mut t, &mut again).unwrap();
            // Any nodes taken as found visible before, of this camera or none, hidden or not.
            let mut seen: Vec<NodeId> = (0..nodes.len() as u32).filter(|&id| (id as u64 ^ !seed).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 60 == 0).collect();
            let mut with_seen = Vec::new();
            hardware_cull_seen(nodes, &this, tau, &previous, &mut seen, &mut t, &mut with_seen).unwrap();
            for v in [&mut want, &mut got, &mut again, &mut with_seen] {
                v.sort_unstable();
            }
            proptest::prop_assert_eq!(&got, &want);
            proptest::prop_assert_eq!(&again, &want);
            proptest::prop_assert_eq!(&with_seen, &want);
            // What it leaves in `seen` is what its tests found visible.
            proptest::prop_assert!(seen.iter().all(|id| t.marked.contains(id)));
            proptest::prop_assert!(coherent.tests <= root_stats.tests, "{coherent:?} vs {root_stats:?}");
            // Every test falls in one place; from the root every test is new; frustum culling
            // makes none.
            let mut none = Vec::new();
            let frustum = hardware_cull(nodes, &this, tau, &mut AllVisible, &mut none).unwrap();
            for s in [&root_stats, &coherent, &frustum] {
                proptest::prop_assert_eq!(s.tests_front + s.tests_siblings + s.tests_new, s.tests, "{:?}", s);
            }
            proptest::prop_assert_eq!(root_stats.tests_new, root_stats.tests);
        }
    }
}
