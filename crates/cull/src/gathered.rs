//! The indices [`gather`] made for each node, kept for the view and tests they were made under,
//! so that a later pass of the same frame that draws the node again copies them instead of
//! testing its clusters and triangles again. In prev, OR draws the last visible sets from the
//! new camera and RVG then draws the new visible set from the same camera: the set changes by
//! a few nodes a frame, so RVG tests almost nothing. In the switch OR and RVG run in different
//! processes, and each gathers its own.
//!
//! It also remembers, per node, whether the small-triangle test paid: where it dropped few of
//! the triangles it tested, drawing them costs lavapipe less than testing them, and the node
//! is drawn without the test for a few views (the frame is the same: such triangles make no
//! fragment).

use crate::cluster::{ClusterStats, ClusterTests, gather};
use crate::view::View;
use osw_scene::NodeId;
use osw_scene::format::ClusterRecord;
use std::collections::{HashMap, hash_map};
use std::ops::Range;

/// One node's gathered indices (`Gathered::indices`), what they were offset by, and its counts.
struct Entry {
    base: u32,
    range: Range<usize>,
    stats: ClusterStats,
}

/// A node whose small-triangle test dropped less than this share of the triangles it tested
/// skips the test for its next [`SMALL_SKIP_VIEWS`] views (the isosurface's fine cuts, whose
/// triangles cover a few pixels, drop about a fifth, the plant's far parts about half:
/// docs/measurements/2026-12-05-triangle-tests.md).
const SMALL_PAYS: f64 = 0.3;
const SMALL_SKIP_VIEWS: u32 = 8;

#[derive(Default)]
pub struct Gathered {
    key: Option<(View, ClusterTests)>,
    nodes: HashMap<NodeId, Entry>,
    indices: Vec<u32>,
    /// Per node whose small-triangle test did not pay, the views left before it runs again.
    small_skipped: HashMap<NodeId, u32>,
}

impl Gathered {
    /// Appends to `out`, and adds to `stats`, what [`gather`] made for `node` (its id, and what
    /// its vertex indices are offset by) under `view` and `tests` since the view last changed; false,
    /// appending nothing, when it has not (the caller then reads the node's geometry, which
    /// for an instance is placed at each read, and calls [`Gathered::gather`]).
    pub fn copy(
        &mut self,
        view: &View,
        tests: ClusterTests,
        (id, base): (NodeId, u32),
        stats: &mut ClusterStats,
        out: &mut Vec<u32>,
    ) -> bool {
        if self.key.as_ref().is_none_or(|(v, t)| v != view || *t != tests) {
            self.key = Some((view.clone(), tests));
            self.nodes.clear();
            self.indices.clear();
        }
        let Some(e) = self.nodes.get(&id) else { return false };
        let indices = &self.indices[e.range.clone()];
        match base.wrapping_sub(e.base) {
            0 => out.extend_from_slice(indices),
            by => out.extend(indices.iter().map(|&i| i.wrapping_add(by))),
        }
        *stats = *stats + e.stats;
        true
    }

    /// Appends to `out`, and adds to `stats`, what [`gather`] would for `node`, taking every
    /// cluster that passes `tests`: copied when the node was gathered under the same view and
    /// tests since the view last changed.
    pub fn gather<I: Copy + Into<u32>>(
        &mut self,
        view: &View,
        tests: ClusterTests,
        (id, base): (NodeId, u32),
        geometry: (&[[f32; 3]], &[I], &[ClusterRecord]),
        stats: &mut ClusterStats,
        out: &mut Vec<u32>,
    ) {
        if self.copy(view, tests, (id, base), stats, out) {
            return;
        }
        let (start, mut s) = (out.len(), ClusterStats::default());
        let skip = match self.small_skipped.entry(id) {
            hash_map::Entry::Occupied(mut left) if tests.small => {
                *left.get_mut() -= 1;
                if *left.get() == 0 {
                    left.remove();
                }
                true
            }
            _ => false,
        };
        gather(view, ClusterTests { small: tests.small && !skip, ..tests }, geometry, &mut s, |_, _| true, base, out);
        let tested = (out.len() - start) as f64 / 3.0 + s.small_culled as f64;
        if tests.small && !skip && (s.small_culled as f64) < SMALL_PAYS * tested {
            self.small_skipped.insert(id, SMALL_SKIP_VIEWS);
        }
        let from = self.indices.len();
        self.indices.extend_from_slice(&out[start..]);
        self.nodes.insert(id, Entry { base, range: from..self.indices.len(), stats: s });
        *stats = *stats + s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use osw_scene::Camera;
    use osw_scene::generators::shapes::add_box;
    use osw_scene::mesh::Mesh;

    #[test]
    fn a_node_whose_small_test_drops_little_skips_it_for_a_few_views() {
        // Ten boxes a few pixels across or more, and two far smaller than a pixel: the test
        // drops only the small ones' triangles.
        let mut m = Mesh::default();
        for i in 0..10 {
            let o = glam::Vec3::new(i as f32 * 3.0, 0.0, 0.0);
            add_box(&mut m, o, o + glam::Vec3::new(2.0, 2.0, 2.0));
        }
        for i in 0..2 {
            let o = glam::Vec3::new(5.0 + i as f32 * 10.0, 2.0, 0.0);
            add_box(&mut m, o, o + glam::Vec3::splat(1e-4));
        }
        let (indices, clusters, _) = osw_scene::cluster::clusterize(&m, None);
        let geometry = (m.positions.as_slice(), indices.as_slice(), clusters.as_slice());
        let all = ClusterTests::default();
        let direct = |view: &View, tests: ClusterTests| {
            let (mut out, mut s) = (Vec::new(), ClusterStats::default());
            gather(view, tests, geometry, &mut s, |_, _| true, 0, &mut out);
            (out, s)
        };
        let mut cache = Gathered::default();
        for k in 0..=SMALL_SKIP_VIEWS + 1 {
            // A new view each time, as each frame's camera.
            let eye = DVec3::new(14.0, 3.0, 25.0 + k as f64 * 0.01);
            let view = View::new(&Camera::look_at(eye, DVec3::new(14.0, 1.0, 0.0), 60.0), DVec3::ZERO, 512, 384, 0.05);
            let (mut out, mut s) = (Vec::new(), ClusterStats::default());
            cache.gather(&view, all, (3, 0), geometry, &mut s, &mut out);
            let (tested, without) = (direct(&view, all), direct(&view, ClusterTests { small: false, ..all }));
            assert!(tested.1.small_culled > 0 && tested.0.len() < without.0.len(), "view {k}: the small boxes are culled");
            let kept = tested.0.len() / 3;
            assert!(
                (tested.1.small_culled as f64) < SMALL_PAYS * (kept + tested.1.small_culled as usize) as f64,
                "view {k}: few: {} of {}",
                tested.1.small_culled,
                kept
            );
            // Tested on the first view and again once the skipped views are over.
            let skipped = (1..=SMALL_SKIP_VIEWS).contains(&k);
            assert_eq!((out, s), if skipped { without.clone() } else { tested }, "view {k}");
        }
    }

    #[test]
    fn a_node_gathered_again_under_the_same_view_gives_what_gather_gives() {
        let mut m = Mesh::default();
        for i in 0..60 {
            let o = glam::Vec3::new((i % 10) as f32 * 3.0, (i / 10) as f32 * 2.0, (i % 4) as f32);
            add_box(&mut m, o, o + glam::Vec3::new(1.0, 0.5 + (i % 3) as f32, 1.5));
        }
        let (indices, clusters, _) = osw_scene::cluster::clusterize(&m, None);
        let geometry = (m.positions.as_slice(), indices.as_slice(), clusters.as_slice());
        let view_at = |eye: DVec3| View::new(&Camera::look_at(eye, DVec3::new(15.0, 5.0, 2.0), 60.0), DVec3::ZERO, 128, 96, 0.05);
        let direct = |view: &View, tests: ClusterTests, base: u32| {
            let (mut out, mut s) = (Vec::new(), ClusterStats::default());
            gather(view, tests, geometry, &mut s, |_, _| true, base, &mut out);
            (out, s)
        };
        let mut cache = Gathered::default();
        let mut via_cache = |view: &View, tests: ClusterTests, base: u32| {
            let (mut out, mut s) = (vec![7], ClusterStats::default());
            cache.gather(view, tests, (3, base), geometry, &mut s, &mut out);
            assert_eq!(out[0], 7, "appends");
            (out[1..].to_vec(), s)
        };
        let (a, b) = (view_at(DVec3::new(10.0, 5.0, 40.0)), view_at(DVec3::new(-20.0, 3.0, 30.0)));
        let all = ClusterTests::default();
        // First, again (copied), another view, another base, other tests, the first view back.
        for (view, tests, base) in [(&a, all, 0), (&a, all, 0), (&b, all, 0), (&b, all, 100), (&b, ClusterTests::NONE, 100), (&a, all, 0)] {
            let want = direct(view, tests, base);
            assert!(!want.0.is_empty(), "the camera sees the boxes");
            assert_eq!(via_cache(view, tests, base), want);
        }
        assert_ne!(direct(&a, all, 0), direct(&b, all, 0), "the two views cull differently");
    }
}
