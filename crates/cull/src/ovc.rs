//! OpenGL-assisted visibility culling (Bartz 1999, Bartz, Meißner and Hüttner), the `ovc` mode:
//! the hierarchy in a depth-ordered list (sec. 3.5's Depth-List), each node popped nearest first,
//! tested against the virtual occlusion buffer (sec. 3.3: its box rasterised against the depth
//! of what was drawn so far) and, when visible, drawn at once if it is a leaf (here: if a LOD
//! meets tau) or replaced by its children that pass the frustum test: frustum and occlusion
//! tests interleaved, node by node, as in the paper's pseudo-code. An occluded node is dropped
//! with its subtree.
//!
//! Two knobs trade error for time, both off by default (conservative):
//! - adaptive culling (sec. 3.4, eq. 1): a visible box whose footprint is small for its size and
//!   depth counts as occluded (see [`adapcull`]);
//! - the cost-adaptive budget (sec. 3.5, eq. 2): once culling has taken `budget_ms` (the
//!   previous frame's render time times F), the remaining nodes are only frustum culled and
//!   drawn.
//!
//! What wgpu changes: the paper read the stencil buffer back (its selection buffer gave z_min);
//! here a box's footprint is counted by the box-test shader into a storage buffer and read back
//! (`osw_gpu`), and the list is ordered by the nearest distance from the eye to the box (the
//! [`DistanceQueue`]), which orders boxes along the view as z_min does.

use crate::distance_queue::DistanceQueue;
use crate::frustum::Containment;
use crate::hc::HcStats;
use crate::hzb::Footprint;
use crate::tester::Occluders;
use crate::view::{Cut, View};
use osw_scene::error_metric::select;
use osw_scene::{Aabb, NodeId};

/// Paper 003's knobs. `OvcOptions::default()` is conservative with no budget: the
/// hierarchical stop-and-wait of CHC sec. 3.3 (the `sw` mode), which is the same
/// front-to-back interleaved traversal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OvcOptions {
    /// Thres_adap of eq. 1 (0: off).
    pub adaptive: f64,
    /// F_graphics of eq. 2: culling may take this times the previous frame's render time
    /// (none: no budget).
    pub budget: Option<f64>,
    /// The box test reads 1 of this many pixel lines a frame (sec. 3.3; 1 reads all):
    /// footprints are scaled back up by it.
    pub sampling: u32,
}

impl Default for OvcOptions {
    fn default() -> Self {
        OvcOptions { adaptive: 0.0, budget: None, sampling: 1 }
    }
}

/// Eq. 1, Adapcull(Obj): the box's footprint (its visible pixels) as a share of its 2D bounding
/// box on screen, divided by the depth factor (Dist(Eye) + Dist(Obj)) / Dist(Eye), where
/// Dist(Obj) is the box's distance to the view plane and Dist(Eye) the eye's, the near plane.
/// The paper's prose ("the percentage of footprints relative to the depth and size of the
/// object") is what this computes; the printed equation lost its footprint term in extraction.
/// A farther or less visible box scores lower; below Thres_adap it counts as occluded.
pub fn adapcull(view: &View, b: &Aabb, footprint: f64) -> f64 {
    let vp = view.view_proj().as_dmat4();
    let Footprint::Rect { x0, y0, x1, y1, .. } = Footprint::of_box(&vp, view, b) else { return f64::INFINITY };
    let clip = |lo: f64, hi: f64, size: u32| (hi.min(size as f64) - lo.max(0.0)).max(1.0);
    let area = clip(x0, x1, view.width) * clip(y0, y1, view.height);
    let forward = view.orientation * glam::DVec3::NEG_Z;
    let (lo, hi) = view.test_box(b);
    let nearest = glam::DVec3::new(
        if forward.x > 0.0 { lo.x } else { hi.x },
        if forward.y > 0.0 { lo.y } else { hi.y },
        if forward.z > 0.0 { lo.z } else { hi.z },
    );
    let dist = nearest.dot(forward).max(0.0);
    footprint / area / ((view.near + dist) / view.near)
}

/// Runs ovc for `cut`'s view at its tau; appends the PVS to `pvs`. `budget_ms`: eq. 2's T_budget for
/// this frame, if any; `elapsed_ms` tells how long the frame's culling has taken so far (a
/// clock; in tests, a count).
pub fn ovc<E>(
    cut: Cut,
    opts: &OvcOptions,
    budget_ms: Option<f64>,
    occ: &mut dyn Occluders<Error = E>,
    elapsed_ms: &mut dyn FnMut() -> f64,
    pvs: &mut Vec<NodeId>,
) -> Result<HcStats, E> {
    let Cut { nodes, view, tau } = cut;
    let mut stats = HcStats::default();
    let mut list = DistanceQueue::new();
    list.push(nodes, view.eye, 0);
    let mut answer = Vec::with_capacity(1);
    let mut testing = true;
    while let Some(id) = list.pop() {
        let b = nodes[id as usize].aabb();
        if view.frustum.classify(&b) == Containment::Outside {
            stats.frustum_culled += 1;
            continue;
        }
        testing = testing && budget_ms.is_none_or(|budget| elapsed_ms() < budget);
        let (visible, pixels) = if view.frustum.needs_no_test(&b) {
            stats.untested += 1;
            (true, None)
        } else if !testing {
            stats.over_budget += 1;
            (true, None)
        } else {
            answer.clear();
            occ.test(view, &[id], &mut answer)?;
            stats.tests += 1;
            (answer[0].visible, answer[0].pixels)
        };
        if !visible {
            stats.occlusion_culled += 1;
            continue;
        }
        let s = select(nodes, id, &view.lod_at(tau));
        // Eq. 1 judges objects, what would be drawn now; a node that is refined further is
        // judged by its children.
        if !s.refine
            && opts.adaptive > 0.0
            && pixels.is_some_and(|p| adapcull(view, &b, p as f64 * opts.sampling.max(1) as f64) < opts.adaptive)
        {
            stats.adaptive_culled += 1;
            stats.occlusion_culled += 1;
            continue;
        }
        if let Some(lod) = s.draw {
            occ.render(&[lod])?;
            pvs.push(lod);
        }
        if s.refine {
            nodes[id as usize].children().for_each(|c| list.push(nodes, view.eye, c));
        }
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hc::hardware_cull;
    use crate::hc::tests::{scene, view_from};
    use crate::tester::{Visibility, VisibilityTester};
    use glam::DVec3;

    /// Visible where a marked node is, with a fixed pixel count; records what was drawn.
    struct Marked {
        visible: Vec<NodeId>,
        pixels: Option<u32>,
        drawn: Vec<NodeId>,
    }

    impl VisibilityTester for Marked {
        type Error = std::convert::Infallible;

        fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error> {
            out.extend(ids.iter().map(|id| Visibility { visible: self.visible.contains(id), pixels: self.pixels }));
            Ok(())
        }
    }

    impl Occluders for Marked {
        fn render(&mut self, lods: &[NodeId]) -> Result<(), Self::Error> {
            self.drawn.extend_from_slice(lods);
            Ok(())
        }
    }

    fn run(opts: &OvcOptions, budget_ms: Option<f64>, t: &mut Marked, tau: f64) -> (Vec<NodeId>, HcStats) {
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let (mut pvs, mut tests) = (Vec::new(), 0.0);
        // A fake clock: each call after a test has cost 1 ms per test so far.
        let s = ovc(
            Cut { nodes: &scene(), view: &v, tau },
            opts,
            budget_ms,
            t,
            &mut || {
                tests += 1.0;
                tests - 1.0
            },
            &mut pvs,
        )
        .unwrap();
        pvs.sort_unstable();
        (pvs, s)
    }

    #[test]
    fn conservative_ovc_finds_what_the_level_traversal_finds_and_draws_it_as_it_goes() {
        for visible in [vec![0, 1, 2], vec![0, 2], vec![0], vec![]] {
            let mut t = Marked { visible: visible.clone(), pixels: None, drawn: Vec::new() };
            let (pvs, s) = run(&OvcOptions::default(), None, &mut t, 0.0);
            let mut want = Vec::new();
            let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
            hardware_cull(&scene(), &v, 0.0, &mut t, &mut want).unwrap();
            want.sort_unstable();
            assert_eq!(pvs, want, "visible {visible:?}");
            let mut drawn = t.drawn.clone();
            drawn.sort_unstable();
            assert_eq!(drawn, pvs, "every node of the PVS is drawn as an occluder when found");
            assert_eq!((s.adaptive_culled, s.over_budget), (0, 0));
        }
    }

    #[test]
    fn adaptive_culling_drops_boxes_with_few_visible_pixels_and_only_those() {
        // Every box visible with 1 pixel: a tiny share of any box at 30 units.
        let opts = |adaptive| OvcOptions { adaptive, ..OvcOptions::default() };
        let mut t = Marked { visible: vec![0, 1, 2], pixels: Some(1), drawn: Vec::new() };
        let (pvs, s) = run(&opts(0.0), None, &mut t, 0.0);
        assert_eq!((pvs, s.adaptive_culled), (vec![4, 6], 0), "threshold 0 is conservative");
        let (pvs, s) = run(&opts(1.0), None, &mut t, 0.0);
        assert_eq!((pvs, s.adaptive_culled, s.occlusion_culled), (vec![], 2, 2), "both leaves dropped, the root refined");
        // At tau 1 from far away the root's HLOD would be drawn: it is judged, and dropped.
        let (pvs, s) = run(&opts(1.0), None, &mut t, 100.0);
        assert_eq!((pvs, s.adaptive_culled), (vec![], 1));
        // Many visible pixels pass the same threshold.
        let mut t = Marked { visible: vec![0, 1, 2], pixels: Some(1_000_000), drawn: Vec::new() };
        assert_eq!(run(&opts(1e-3), None, &mut t, 0.0).0, vec![4, 6]);
    }

    #[test]
    fn the_budget_stops_testing_and_frustum_culls_the_rest() {
        // Nothing is visible: without a budget every box is tested and the PVS is empty. With a
        // budget of 1 ms on a clock that advances 1 ms per test, one test is made (the root:
        // occluded, so nothing is left). With the leaves visible and the root taken untested,
        // the budget of 0 ms makes no test at all and draws what the frustum keeps.
        let opts = OvcOptions::default();
        let mut t = Marked { visible: vec![], pixels: None, drawn: Vec::new() };
        let (pvs, s) = run(&opts, None, &mut t, 0.0);
        assert_eq!((pvs.len(), s.tests, s.over_budget), (0, 1, 0));
        let (pvs, s) = run(&opts, Some(0.0), &mut t, 0.0);
        assert_eq!((pvs, s.tests, s.over_budget), (vec![4, 6], 0, 3), "over budget: frustum culling only");
        for budget in [1.0, 2.0, 3.0] {
            let mut t = Marked { visible: vec![0, 1, 2], pixels: None, drawn: Vec::new() };
            let (pvs, s) = run(&opts, Some(budget), &mut t, 0.0);
            // Tests stay within the budget plus one (the clock is read before each test).
            assert!(s.tests as f64 <= budget + 1.0, "{s:?}");
            assert_eq!(s.tests + s.over_budget, 3, "{s:?}");
            assert_eq!(pvs, vec![4, 6]);
        }
    }

    #[test]
    fn the_depth_factor_and_the_footprint_share_order_adapcull() {
        let v = view_from(DVec3::new(5.5, 0.5, 30.0), DVec3::new(5.5, 0.5, 0.0));
        let near = Aabb::new(glam::Vec3::new(5.0, 0.0, 0.0), glam::Vec3::new(6.0, 1.0, 1.0));
        let far = Aabb::new(glam::Vec3::new(5.0, 0.0, -20.0), glam::Vec3::new(6.0, 1.0, -19.0));
        // Half of each box visible: the share is the same, the farther box scores lower.
        let half = |b: &Aabb| match Footprint::of_box(&v.view_proj().as_dmat4(), &v, b) {
            Footprint::Rect { x0, y0, x1, y1, .. } => 0.5 * (x1 - x0) * (y1 - y0),
            Footprint::Behind => unreachable!("in front"),
        };
        assert!(adapcull(&v, &near, half(&near)) > adapcull(&v, &far, half(&far)), "farther scores lower");
        assert!(adapcull(&v, &near, 10.0) < adapcull(&v, &near, 20.0), "more footprint scores higher");
        assert_eq!(adapcull(&v, &near, 0.0), 0.0);
    }
}
