//! What [`gather`] made of each node's clusters, kept for the view and tests it was made
//! under, so that a later pass of the same frame that draws the node again copies it instead of
//! testing its clusters and triangles again: each cluster is tested once a view, and its
//! triangles once, when a pass first takes it. In prev, OR draws the last visible sets from the
//! new camera (with HC's notes, only the clusters found visible two frames back), HC its
//! additions, and RVG the new visible set (with this frame's notes) from the same camera: the
//! set changes by a few nodes a frame and the notes by a few clusters, so RVG tests almost
//! nothing. In the switch OR and RVG run in different processes, and each gathers its own.
//!
//! It also remembers, per node, whether the small-triangle test paid: where it dropped few of
//! the triangles it tested, drawing them costs lavapipe less than testing them, and the node
//! is drawn without the test for a few views (the frame is the same: such triangles make no
//! fragment).

use crate::cluster::{ClusterStats, ClusterTests, Out, cluster_indices, push_triangles, test_cluster};
use crate::triangle::TriangleView;
use crate::view::View;
use osw_scene::NodeId;
use osw_scene::block::{Geometry, Indices};
use std::collections::{HashMap, hash_map};
use std::ops::Range;

/// One node under the kept view: what its indices were offset by, its clusters past the
/// cluster tests (a range of `Gathered::kept`) and those tests' counts, whether its
/// small-triangle test runs, and the triangles that test has seen and dropped so far.
struct Entry {
    base: u32,
    kept: Range<usize>,
    stats: ClusterStats,
    small: bool,
    small_tested: u64,
    small_culled: u64,
}

/// A cluster past the cluster tests: its index among the node's opaque clusters, whether its
/// triangles may face away, and, once a pass took it, its triangles past the triangle tests.
struct Kept {
    k: u32,
    backface: bool,
    triangles: Option<Tested>,
}

/// A cluster's triangles past the triangle tests (a range of `Gathered::indices`), and how many
/// faced away and covered no pixel centre.
struct Tested {
    range: Range<usize>,
    backface_culled: u32,
    small_culled: u32,
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
    kept: Vec<Kept>,
    indices: Vec<u32>,
    /// Per node whose small-triangle test did not pay, the views left before it runs again.
    small_skipped: HashMap<NodeId, u32>,
}

impl Gathered {
    /// Appends to `out` what [`gather`] makes of node `id`'s opaque clusters under `view` and
    /// `tests`, of those past the cluster tests only the ones `select` takes (by index).
    /// `geometry` reads the node's (an instance's is placed at each read): only when something
    /// of it was not tested yet.
    ///
    /// [`gather`]: crate::cluster::gather
    pub fn gather<'g, E>(
        &mut self,
        view: &View,
        tests: ClusterTests,
        id: NodeId,
        mut geometry: impl FnMut() -> Result<Geometry<'g>, E>,
        select: &mut dyn FnMut(usize) -> bool,
        out: &mut Out,
    ) -> Result<(), E> {
        let base = out.base;
        self.begin(view, tests);
        let mut g = None;
        let e = match self.nodes.entry(id) {
            hash_map::Entry::Occupied(e) => e.into_mut(),
            hash_map::Entry::Vacant(e) => {
                let g = g.insert(geometry()?);
                let (from, mut s) = (self.kept.len(), ClusterStats::default());
                for (k, c) in g.clusters[..g.opaque].iter().enumerate() {
                    if let Some(backface) = test_cluster(view, tests, c, g.cut(k), &mut s) {
                        self.kept.push(Kept { k: k as u32, backface, triangles: None });
                    }
                }
                let small = tests.small && !skips_small(&mut self.small_skipped, id);
                e.insert(Entry { base, kept: from..self.kept.len(), stats: s, small, small_tested: 0, small_culled: 0 })
            }
        };
        *out.stats = *out.stats + e.stats;
        let triangles = TriangleView::new(view);
        for c in &mut self.kept[e.kept.clone()] {
            if !select(c.k as usize) {
                continue;
            }
            if c.triangles.is_none() {
                if g.is_none() {
                    g = Some(geometry()?);
                }
                let Some(g) = &g else { continue };
                let (from, mut s) = (self.indices.len(), ClusterStats::default());
                let tests = ClusterTests { backface: c.backface, small: e.small, ..ClusterTests::NONE };
                let (positions, cluster) = (&g.positions[..], &g.clusters[c.k as usize]);
                let kept = &mut Out { indices: &mut self.indices, base: e.base, stats: &mut s };
                match &g.indices {
                    Indices::U16(ix) => push_triangles(&triangles, tests, positions, cluster_indices(ix, cluster), kept),
                    Indices::U32(ix) => push_triangles(&triangles, tests, positions, cluster_indices(ix, cluster), kept),
                }
                let made = self.indices.len();
                e.small_tested += (made - from) as u64 / 3 + s.small_culled;
                e.small_culled += s.small_culled;
                // At most the cluster's triangles, whose index count is a u32.
                let (backface_culled, small_culled) = (s.backface_culled as u32, s.small_culled as u32);
                c.triangles = Some(Tested { range: from..made, backface_culled, small_culled });
            }
            let Some(t) = &c.triangles else { continue };
            match base.wrapping_sub(e.base) {
                0 => out.indices.extend_from_slice(&self.indices[t.range.clone()]),
                by => out.indices.extend(self.indices[t.range.clone()].iter().map(|&i| i.wrapping_add(by))),
            }
            out.stats.backface_culled += u64::from(t.backface_culled);
            out.stats.small_culled += u64::from(t.small_culled);
        }
        Ok(())
    }

    /// Keeps what is made for `view` and `tests` from now on, forgetting what was made for
    /// others; the nodes whose small-triangle test did not pay under the last view skip it.
    fn begin(&mut self, view: &View, tests: ClusterTests) {
        if self.key.as_ref().is_some_and(|(v, t)| v == view && *t == tests) {
            return;
        }
        for (&id, e) in &self.nodes {
            if e.small && e.small_tested > 0 && (e.small_culled as f64) < SMALL_PAYS * e.small_tested as f64 {
                self.small_skipped.insert(id, SMALL_SKIP_VIEWS);
            }
        }
        self.key = Some((view.clone(), tests));
        self.nodes.clear();
        self.kept.clear();
        self.indices.clear();
    }
}

/// Whether node `id` skips the small-triangle test under a new view, counting the view.
fn skips_small(small_skipped: &mut HashMap<NodeId, u32>, id: NodeId) -> bool {
    let hash_map::Entry::Occupied(mut left) = small_skipped.entry(id) else { return false };
    *left.get_mut() -= 1;
    if *left.get() == 0 {
        left.remove();
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cluster::gather;
    use glam::DVec3;
    use osw_scene::Camera;
    use osw_scene::format::ClusterRecord;
    use osw_scene::generators::shapes::add_box;
    use osw_scene::mesh::Mesh;
    use std::borrow::Cow;
    use std::convert::Infallible;

    /// A mesh's vertices, indices in cluster order and clusters.
    type Block<'a> = (&'a [[f32; 3]], &'a [u32], &'a [ClusterRecord]);

    /// What `gather` appends of `b` under `view`, and its counts.
    fn direct(view: &View, tests: ClusterTests, b: Block, base: u32) -> (Vec<u32>, ClusterStats) {
        let (mut out, mut s) = (Vec::new(), ClusterStats::default());
        gather(view, tests, b.0, b.1, b.2, &[], &mut Out { indices: &mut out, base, stats: &mut s });
        (out, s)
    }

    /// What `cache` appends of block `b` as node `id`, of the clusters `select` takes, and its
    /// counts; `reads` counts the reads of the block.
    fn cached(
        cache: &mut Gathered,
        view: &View,
        tests: ClusterTests,
        (id, base): (NodeId, u32),
        b: Block,
        select: &mut dyn FnMut(usize) -> bool,
        reads: &mut u32,
    ) -> (Vec<u32>, ClusterStats) {
        let (mut out, mut s) = (vec![7], ClusterStats::default());
        let read = || {
            *reads += 1;
            Ok::<_, Infallible>(Geometry {
                positions: Cow::Borrowed(b.0),
                colors: &[],
                normals: Cow::Borrowed(&[]),
                texcoords: &[],
                indices: Indices::U32(Cow::Borrowed(b.1)),
                clusters: Cow::Borrowed(b.2),
                cuts: &[],
                occluders: b.2.len(),
                opaque: b.2.len(),
            })
        };
        let Ok(()) = cache.gather(view, tests, id, read, select, &mut Out { indices: &mut out, base, stats: &mut s });
        assert_eq!(out[0], 7, "appends");
        (out[1..].to_vec(), s)
    }

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
        let osw_scene::cluster::Clustered { indices, clusters, .. } = osw_scene::cluster::clusterize(&m, None);
        let b = (m.positions.as_slice(), indices.as_slice(), clusters.as_slice());
        let all = ClusterTests::default();
        let mut cache = Gathered::default();
        for k in 0..=SMALL_SKIP_VIEWS + 1 {
            // A new view each time, as each frame's camera.
            let eye = DVec3::new(14.0, 3.0, 25.0 + k as f64 * 0.01);
            let view = View::new(&Camera::look_at(eye, DVec3::new(14.0, 1.0, 0.0), 60.0), DVec3::ZERO, 512, 384, 0.05);
            let (out, s) = cached(&mut cache, &view, all, (3, 0), b, &mut |_| true, &mut 0);
            let (tested, without) = (direct(&view, all, b, 0), direct(&view, ClusterTests { small: false, ..all }, b, 0));
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

    /// Each pass takes some clusters of the node (OR those visible two frames back, RVG those
    /// visible now and not drawn yet): what it gets is what `gather` gives of those, the node
    /// read only while something it takes was not tested yet.
    #[test]
    fn a_node_gathered_again_under_the_same_view_gives_what_gather_gives() {
        let mut m = Mesh::default();
        for i in 0..60 {
            let o = glam::Vec3::new((i % 10) as f32 * 3.0, (i / 10) as f32 * 2.0, (i % 4) as f32);
            add_box(&mut m, o, o + glam::Vec3::new(1.0, 0.5 + (i % 3) as f32, 1.5));
        }
        let osw_scene::cluster::Clustered { indices, clusters, .. } = osw_scene::cluster::clusterize(&m, None);
        let b = (m.positions.as_slice(), indices.as_slice(), clusters.as_slice());
        let view_at = |eye: DVec3| View::new(&Camera::look_at(eye, DVec3::new(15.0, 5.0, 2.0), 60.0), DVec3::ZERO, 128, 96, 0.05);
        // gather's of the clusters `take` takes: each cluster alone, the counts of the
        // cluster tests from all of them.
        let want = |view: &View, tests: ClusterTests, base: u32, take: &dyn Fn(usize) -> bool| {
            let (mut out, mut s) = (Vec::new(), direct(view, tests, b, base).1);
            (s.backface_culled, s.small_culled) = (0, 0);
            for k in (0..clusters.len()).filter(|&k| take(k)) {
                let (one, t) = direct(view, tests, (b.0, b.1, &clusters[k..=k]), base);
                out.extend(one);
                (s.backface_culled, s.small_culled) = (s.backface_culled + t.backface_culled, s.small_culled + t.small_culled);
            }
            (out, s)
        };
        let mut cache = Gathered::default();
        let (a, c) = (view_at(DVec3::new(10.0, 5.0, 40.0)), view_at(DVec3::new(-20.0, 3.0, 30.0)));
        let all = ClusterTests::default();
        type Take<'a> = &'a dyn Fn(usize) -> bool;
        let (even, odd, every): (Take, Take, Take) = (&|k| k % 2 == 0, &|k| k % 2 == 1, &|_| true);
        // Some clusters, the others (tested now), all (copied), another view, another base,
        // other tests, the first view back: with whether the node is read.
        for (view, tests, base, take, read) in [
            (&a, all, 0, even, true),
            (&a, all, 0, odd, true),
            (&a, all, 0, every, false),
            (&a, all, 0, even, false),
            (&c, all, 0, every, true),
            (&c, all, 100, every, false),
            (&c, ClusterTests::NONE, 100, odd, true),
            (&a, all, 0, every, true),
        ] {
            let mut reads = 0;
            let got = cached(&mut cache, view, tests, (3, base), b, &mut |k| take(k), &mut reads);
            assert!(!got.0.is_empty(), "the camera sees the boxes");
            assert_eq!(got, want(view, tests, base, take));
            assert_eq!(reads, u32::from(read));
            if std::ptr::eq(take, every) {
                assert_eq!(got, direct(view, tests, b, base), "all: gather's");
            }
        }
        assert_ne!(direct(&a, all, b, 0), direct(&c, all, b, 0), "the two views cull differently");
    }
}
