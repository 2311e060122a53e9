//! The hardware cull (HC): paper 000 alg. 4.1, breadth first with one batch of occlusion tests
//! per level of the hierarchy (sec. 4.7.1), LOD selection by projected error against tau
//! (sec. 4.1) and the pixel-count stop (sec. 4.7.2).
//!
//! For each level: drop boxes outside the frustum; boxes that contain the eye or cross the near
//! plane are visible without a test; test the rest as one batch. A visible node whose coarsest
//! fitting LOD or HLOD meets tau goes into the PVS; otherwise its children form the next level.
//! A visible group whose box shows fewer than tau pixels stops at its HLOD: its error cannot
//! show in more pixels than are visible (sec. 4.7.2).

use crate::frustum::Containment;
use crate::tester::{Visibility, VisibilityTester};
use crate::view::View;
use osw_scene::error_metric::select_lod;
use osw_scene::format::NodeKind;
use osw_scene::{NodeId, NodeRecord};

/// Counts of one traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HcStats {
    /// Levels (batches) traversed.
    pub levels: u32,
    /// Boxes sent to the tester.
    pub tests: u32,
    /// Boxes accepted without a test (eye inside, or crossing the near plane).
    pub untested: u32,
    pub frustum_culled: u32,
    pub occlusion_culled: u32,
    /// Groups that stopped at their HLOD because few of their pixels are visible.
    pub pixel_stops: u32,
}

/// Runs HC from the root for `view` at `tau` pixels of error. Appends the PVS (LOD and HLOD
/// node ids, in the order found) to `pvs`.
pub fn hardware_cull(nodes: &[NodeRecord], view: &View, tau: f64, tester: &mut dyn VisibilityTester, pvs: &mut Vec<NodeId>) -> HcStats {
    let mut stats = HcStats::default();
    let mut level: Vec<NodeId> = vec![0];
    let (mut batch, mut accepted, mut answers, mut next) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    while !level.is_empty() {
        stats.levels += 1;
        batch.clear();
        accepted.clear();
        for &id in &level {
            let b = nodes[id as usize].aabb();
            match view.frustum.classify(&b) {
                Containment::Outside => stats.frustum_culled += 1,
                _ if view.frustum.needs_no_test(&b) => accepted.push(id),
                _ => batch.push(id),
            }
        }
        answers.clear();
        if !batch.is_empty() {
            tester.test(view, &batch, &mut answers);
            assert_eq!(answers.len(), batch.len(), "tester must answer every box");
            if tester.tests() {
                stats.tests += batch.len() as u32;
            }
        }
        stats.untested += accepted.len() as u32;
        next.clear();
        let untested = accepted.iter().map(|&id| (id, Visibility { visible: true, pixels: None }));
        for (id, vis) in batch.iter().copied().zip(answers.iter().copied()).chain(untested) {
            if !vis.visible {
                stats.occlusion_culled += 1;
                continue;
            }
            let n = &nodes[id as usize];
            if let Some(lod) = select_lod(nodes, id, view.eye, view.focal_px, tau) {
                pvs.push(lod);
            } else if let (Some(px), NodeKind::Group, true) = (vis.pixels, n.kind(), n.lod_count > 0) {
                if (px as f64) < tau {
                    stats.pixel_stops += 1;
                    pvs.push(n.first_lod + n.lod_count - 1);
                } else {
                    next.extend(n.children());
                }
            } else {
                next.extend(n.children());
            }
        }
        std::mem::swap(&mut level, &mut next);
    }
    stats
}

/// HC with every test in one batch: first collects every BVH node the level-by-level
/// traversal could visit (in the frustum, under ancestors that do not meet tau), tests them all
/// at once, then runs [`hardware_cull`] on the answers. Same answers per node, so the same PVS
/// as level by level; it tests more boxes (also those under occluded nodes) in one round trip
/// instead of one per level. Pays when a test is cheap and a round trip is not (the pyramid
/// test: sec. 4.7.1 batches per level because 2003 queries were the other way round).
pub fn hardware_cull_one_batch(
    nodes: &[NodeRecord],
    view: &View,
    tau: f64,
    tester: &mut dyn VisibilityTester,
    pvs: &mut Vec<NodeId>,
) -> HcStats {
    let mut candidates = Vec::new();
    let mut stack = vec![0u32];
    while let Some(id) = stack.pop() {
        let n = &nodes[id as usize];
        let b = n.aabb();
        if view.frustum.classify(&b) == Containment::Outside {
            continue;
        }
        if !view.frustum.needs_no_test(&b) {
            candidates.push(id);
        }
        if select_lod(nodes, id, view.eye, view.focal_px, tau).is_none() {
            stack.extend(n.children());
        }
    }
    candidates.sort_unstable();
    let mut answers = Vec::with_capacity(candidates.len());
    if !candidates.is_empty() {
        tester.test(view, &candidates, &mut answers);
        assert_eq!(answers.len(), candidates.len(), "tester must answer every box");
    }
    let mut answered = Answered { ids: &candidates, answers: &answers };
    let mut stats = hardware_cull(nodes, view, tau, &mut answered, pvs);
    (stats.tests, stats.levels) = (if tester.tests() { candidates.len() as u32 } else { 0 }, 1);
    stats
}

/// Answers looked up from a batch tested beforehand.
struct Answered<'a> {
    /// Sorted.
    ids: &'a [NodeId],
    answers: &'a [Visibility],
}

impl VisibilityTester for Answered<'_> {
    fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) {
        // Every node the traversal tests was collected: same frustum and tau rules.
        out.extend(ids.iter().map(|id| self.ids.binary_search(id).map_or(Visibility { visible: true, pixels: None }, |k| self.answers[k])));
    }

    fn tests(&self) -> bool {
        false
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::tester::AllVisible;
    use glam::DVec3;
    use osw_scene::Camera;

    /// A hand-built scene: root group 0 over leaves 1 (x in [0,1]) and 2 (x in [10,11]);
    /// node 3 is the root's HLOD (error 0.5); 4 and 5 are leaf 1's levels 0 and 1 (error 0.1);
    /// 6 is leaf 2's level 0. All boxes span y, z in [0, 1].
    pub(crate) fn scene() -> Vec<NodeRecord> {
        let node = |kind: NodeKind, x0: f32, x1: f32, error: f32, parent: u32, children: (u32, u32), lods: (u32, u32)| NodeRecord {
            bbox_min: [x0, 0.0, 0.0],
            bbox_max: [x1, 1.0, 1.0],
            kind: kind as u32,
            error,
            parent,
            first_child: children.0,
            child_count: children.1,
            first_lod: lods.0,
            lod_count: lods.1,
            ..bytemuck::Zeroable::zeroed()
        };
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
        fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) {
            self.batches.push(ids.to_vec());
            out.extend(ids.iter().map(|id| Visibility { visible: self.visible.contains(id), pixels: self.pixels }));
        }
    }

    #[test]
    fn tau_zero_draws_every_leaf_at_full_detail() {
        // Expected PVS: level 0 of both leaves, {4, 6}.
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let mut pvs = Vec::new();
        let s = hardware_cull(&n, &v, 0.0, &mut AllVisible, &mut pvs);
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
        hardware_cull(&n, &v, 1.0, &mut AllVisible, &mut pvs);
        assert_eq!(pvs, vec![3]);
    }

    #[test]
    fn occluded_leaf_is_culled_and_levels_are_batched() {
        // Only leaf 2 and the root visible: PVS = {6}; batches = [[0], [1, 2]].
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let mut t = Fixed { visible: vec![0, 2], pixels: None, batches: Vec::new() };
        let mut pvs = Vec::new();
        let s = hardware_cull(&n, &v, 0.0, &mut t, &mut pvs);
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
        let s = hardware_cull(&n, &v, 0.0, &mut t, &mut pvs);
        assert_eq!(pvs, vec![4]);
        assert_eq!(s.frustum_culled, 1);
        assert_eq!(s.untested, 2);
        assert!(t.batches.is_empty());
    }

    #[test]
    fn one_batch_gives_the_same_pvs_as_level_batches() {
        let n = scene();
        for (eye, visible) in
            [(DVec3::new(5.5, 0.5, 30.0), vec![0, 2]), (DVec3::new(5.5, 0.5, 30.0), vec![0, 1, 2]), (DVec3::new(5.5, 0.5, 1e4), vec![0])]
        {
            let v = view_from(eye, DVec3::new(5.5, 0.5, 0.0));
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let mut t = Fixed { visible: visible.clone(), pixels: None, batches: Vec::new() };
            hardware_cull(&n, &v, 0.0, &mut t, &mut a);
            let mut t = Fixed { visible, pixels: None, batches: Vec::new() };
            let s = hardware_cull_one_batch(&n, &v, 0.0, &mut t, &mut b);
            a.sort();
            b.sort();
            assert_eq!(a, b);
            assert_eq!(t.batches.len(), 1, "one round trip");
            assert_eq!(s.tests, 3, "root and both leaves tested at once");
        }
    }

    #[test]
    fn few_visible_pixels_stop_at_the_hlod() {
        // From 30 units the root's HLOD shows 0.5 * 86.6 / 29 = 1.5 px of error > tau = 1, but
        // the tester counts fewer visible pixels (0) than tau: stop at the HLOD.
        let n = scene();
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let mut t = Fixed { visible: vec![0, 1, 2], pixels: Some(0), batches: Vec::new() };
        let mut pvs = Vec::new();
        let s = hardware_cull(&n, &v, 1.0, &mut t, &mut pvs);
        assert_eq!(pvs, vec![3]);
        assert_eq!(s.pixel_stops, 1);
    }
}
