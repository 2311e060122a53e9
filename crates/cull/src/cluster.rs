//! Cluster culling inside the nodes a pass draws (see `osw_scene::cluster`): a node of the PVS
//! is visible somewhere, not everywhere. Its clusters wholly outside the frustum, or whose
//! every triangle faces away from the eye (meshopt's normal cone, kept only for closed meshes
//! wound outwards), cover no pixel that another triangle of the frame does not cover nearer, so
//! they are skipped. Inside the clusters kept, [`crate::triangle`] drops the triangles that face
//! away or cover no pixel centre. RVG and OR also skip the clusters that HC found hidden
//! behind the depth it tested against ([`VisibleClusters`]). All tests are conservative.

use crate::triangle::TriangleView;
use crate::view::View;
use glam::DVec3;
use osw_scene::NodeId;
use osw_scene::cluster::NO_CONE;
use osw_scene::format::{ClusterRecord, Cut};

/// Which cluster and triangle tests a pass runs (each can be turned off alone to show what it
/// culls and that the frame does not change). The triangle tests pay on lavapipe, which sets
/// up each triangle it is given on the CPU (2M plant walk, tau 0, prev: 70,657 -> 24,171
/// triangles a frame, 5.6 times the exactly visible ones, where culling whole clusters exactly
/// would leave 3.9 times). The occlusion test (prev and the switch) is HC's: the clusters of
/// its visible set that its depth pyramid hides are left out by RVG and by a later OR
/// (`osw_render::pass::note_clusters`, [`VisibleClusters`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClusterTests {
    pub frustum: bool,
    pub cone: bool,
    /// Per triangle of a cluster drawn: back faces of closed parts ([`crate::triangle`]).
    pub backface: bool,
    /// Per triangle of a cluster drawn: no pixel centre inside its screen bounds.
    pub small: bool,
    /// HC's notes of hidden clusters (prev and the switch; the other modes have no pyramid).
    pub occlusion: bool,
}

impl ClusterTests {
    pub const ALL: ClusterTests = ClusterTests { frustum: true, cone: true, backface: true, small: true, occlusion: true };
    pub const NONE: ClusterTests = ClusterTests { frustum: false, cone: false, backface: false, small: false, occlusion: false };
}

impl Default for ClusterTests {
    fn default() -> ClusterTests {
        ClusterTests::ALL
    }
}

/// The names of the tests, in the order a list gives them.
const TEST_NAMES: [&str; 5] = ["frustum", "cone", "backface", "small", "occlusion"];

impl ClusterTests {
    fn flags(&mut self) -> [&mut bool; 5] {
        [&mut self.frustum, &mut self.cone, &mut self.backface, &mut self.small, &mut self.occlusion]
    }
}

/// A comma-separated list of test names, or `none`.
impl std::str::FromStr for ClusterTests {
    type Err = String;

    fn from_str(s: &str) -> Result<ClusterTests, String> {
        let mut t = ClusterTests::NONE;
        if s.trim() == "none" {
            return Ok(t);
        }
        for name in s.split(',').map(str::trim) {
            let k = TEST_NAMES.iter().position(|n| *n == name);
            *t.flags()[k.ok_or_else(|| format!("{s:?}: expected a list of frustum, cone, backface, small and occlusion, or none"))?] = true;
        }
        Ok(t)
    }
}

/// The list [`ClusterTests::from_str`](std::str::FromStr) reads.
impl std::fmt::Display for ClusterTests {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let mut t = *self;
        let on: Vec<&str> = TEST_NAMES.iter().zip(t.flags()).filter(|(_, on)| **on).map(|(n, _)| *n).collect();
        f.write_str(if on.is_empty() { "none".into() } else { on.join(",") }.as_str())
    }
}

/// Counts of one pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClusterStats {
    /// Clusters of the nodes drawn that the cut takes.
    pub clusters: u64,
    pub frustum_culled: u64,
    pub cone_culled: u64,
    /// Hidden behind what RVG drew first, and not drawn.
    pub occlusion_culled: u64,
    /// Triangles of the clusters drawn that face away, or cover no pixel centre.
    pub backface_culled: u64,
    pub small_culled: u64,
}

impl std::ops::Add for ClusterStats {
    type Output = ClusterStats;
    fn add(self, o: ClusterStats) -> ClusterStats {
        ClusterStats {
            clusters: self.clusters + o.clusters,
            frustum_culled: self.frustum_culled + o.frustum_culled,
            cone_culled: self.cone_culled + o.cone_culled,
            occlusion_culled: self.occlusion_culled + o.occlusion_culled,
            backface_culled: self.backface_culled + o.backface_culled,
            small_culled: self.small_culled + o.small_culled,
        }
    }
}

/// Which clusters of a frame's visible set HC found not hidden against its depth pyramid, a
/// bit each per LOD node it looked at (`osw_render::pass::note_clusters`). RVG draws only
/// those; the switch's HC node sends them to RVG as a [`VisibleClusters::mask`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VisibleClusters {
    /// The nodes looked at, in increasing id order, each with where its bits start.
    nodes: Vec<(NodeId, usize)>,
    /// A bit per opaque cluster of each node in turn, 1 where visible, packed from the low bit
    /// of the first byte: the mask itself.
    bits: Vec<u8>,
    /// Bits in use.
    len: usize,
}

impl VisibleClusters {
    /// Whether cluster `cluster` of node `id` is drawn: found visible, or not looked at (of a
    /// node HC did not find, drawn whole; or outside the cut HC's camera took).
    pub fn takes(&self, id: NodeId, cluster: usize) -> bool {
        let Ok(i) = self.nodes.binary_search_by_key(&id, |n| n.0) else { return true };
        let end = self.nodes.get(i + 1).map_or(self.len, |n| n.1);
        let at = self.nodes[i].1 + cluster;
        at < end && self.bits[at / 8] >> (at % 8) & 1 != 0
    }

    /// Looks at node `id` (above every node looked at before) of `count` opaque clusters, none
    /// visible yet.
    pub fn look_at(&mut self, id: NodeId, count: u32) {
        debug_assert!(self.nodes.last().is_none_or(|n| n.0 < id), "nodes in increasing id order");
        self.nodes.push((id, self.len));
        self.len += count as usize;
        self.bits.resize(self.len.div_ceil(8), 0);
    }

    /// Marks cluster `cluster` of the node looked at last visible.
    pub fn mark(&mut self, cluster: usize) {
        let at = self.nodes.last().expect("a node looked at").1 + cluster;
        debug_assert!(at < self.len, "a cluster of the node");
        self.bits[at / 8] |= 1 << (at % 8);
    }

    /// The bits of the nodes looked at, node by node in id order, a bit per opaque cluster:
    /// what the display needs to know, since it holds the same scene.
    pub fn mask(&self) -> &[u8] {
        &self.bits
    }

    /// The clusters a [`VisibleClusters::mask`] of `pvs` (sorted) says, `count(id)` bits a
    /// node, or what is wrong with it: its length must be the one the scene's cluster counts
    /// give, its padding zero.
    pub fn from_mask(pvs: &[NodeId], count: impl Fn(NodeId) -> u32, mask: Vec<u8>) -> Result<VisibleClusters, MaskError> {
        let mut v = VisibleClusters::default();
        for &id in pvs {
            v.nodes.push((id, v.len));
            v.len += count(id) as usize;
        }
        if mask.len() != v.len.div_ceil(8) {
            return Err(MaskError::Length { bytes: mask.len(), nodes: pvs.len(), clusters: v.len });
        }
        if !v.len.is_multiple_of(8) && mask.last().is_some_and(|&b| b >> (v.len % 8) != 0) {
            return Err(MaskError::Padding);
        }
        v.bits = mask;
        Ok(v)
    }
}

/// Why a cluster mask does not fit the visible set it came with
/// ([`VisibleClusters::from_mask`]).
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
pub enum MaskError {
    #[error("a cluster mask of {bytes} bytes for {nodes} nodes of {clusters} clusters")]
    Length { bytes: usize, nodes: usize, clusters: usize },
    #[error("a cluster mask with bits set past its last cluster")]
    Padding,
}

/// Where gathering appends a node's triangles: `indices` offset by `base` (where the node's
/// vertices start in the arena), and in `stats` what the tests dropped.
pub struct Out<'a> {
    pub indices: &'a mut Vec<u32>,
    pub base: u32,
    pub stats: &'a mut ClusterStats,
}

/// Appends to `out` the clusters of one node (`positions`, `indices` in cluster order,
/// `clusters` and their `cuts`, none outside a cluster hierarchy) that the cut of `view.lod`
/// takes and that may cover a pixel, less the triangles the triangle tests find covering none.
pub fn gather<I: Copy + Into<u32>>(
    view: &View,
    tests: ClusterTests,
    positions: &[[f32; 3]],
    indices: &[I],
    clusters: &[ClusterRecord],
    cuts: &[Cut],
    out: &mut Out,
) {
    let triangles = TriangleView::new(view);
    for (k, c) in clusters.iter().enumerate() {
        if let Some(backface) = test_cluster(view, tests, c, cuts.get(k).unwrap_or(&Cut::ALWAYS), out.stats) {
            push_triangles(&triangles, ClusterTests { backface, ..tests }, positions, cluster_indices(indices, c), out);
        }
    }
}

/// The cluster tests of [`gather`] on cluster `c`, drawn where the cut takes `cut`, counted in
/// `stats`: `None` when the cut does not take it or it covers no pixel, else whether its
/// triangles may face away (the back-face test then runs on each).
pub fn test_cluster(view: &View, tests: ClusterTests, c: &ClusterRecord, cut: &Cut, stats: &mut ClusterStats) -> Option<bool> {
    // A cluster hierarchy's node holds clusters of several levels; the cut takes some.
    if !view.lod.takes(cut) {
        return None;
    }
    stats.clusters += 1;
    let center = DVec3::from(c.center.map(f64::from));
    // The sphere grown by its centre's f32 rounding, and the eye's (the GPU makes vertices
    // camera-relative in f32; see View::test_box).
    let radius = c.radius as f64 * (1.0 + 1e-5) + center.abs().max_element() * 2.4e-7 + view.eye.abs().max_element() * 2.4e-7;
    if tests.frustum && view.frustum.sphere_outside(center, radius) {
        stats.frustum_culled += 1;
        return None;
    }
    // A single-sided surface is never drawn from behind: its back faces are dropped in every
    // pass, whatever its tests, so that OR's depth, RVG's frame and exact visibility agree.
    let single = c.single_sided();
    let outside_closed = single || (c.cone_cutoff < NO_CONE && eye_outside_closed(c, view));
    if (tests.cone || single) && outside_closed && faces_away(c, center, radius, view) {
        stats.cone_culled += 1;
        return None;
    }
    // A cluster whose every triangle faces the eye has no back face to drop.
    Some((tests.backface || single) && outside_closed && !faces_toward(c, center, radius, view))
}

/// Cluster `c`'s triangles in a block's `indices`.
pub fn cluster_indices<'a, I>(indices: &'a [I], c: &ClusterRecord) -> &'a [I] {
    &indices[c.first_index as usize..(c.first_index + c.index_count) as usize]
}

/// Appends to `out` the triangles `ix` of one cluster, less those that face away (with
/// `tests.backface`) or cover no pixel centre (with `tests.small`), counted in its stats.
pub fn push_triangles<I: Copy + Into<u32>>(triangles: &TriangleView, tests: ClusterTests, positions: &[[f32; 3]], ix: &[I], out: &mut Out) {
    let (backface, small, base) = (tests.backface, tests.small, out.base);
    if !backface && !small {
        out.indices.extend(ix.iter().map(|&i| base + i.into()));
        return;
    }
    for t in ix.chunks_exact(3) {
        // Written out: `[0, 1, 2].map(..)` was left a call per triangle where this loop is
        // inlined into a larger caller (measured: 5% of vfc's frame).
        let tri = [positions[t[0].into() as usize], positions[t[1].into() as usize], positions[t[2].into() as usize]];
        if backface && triangles.faces_away(tri) {
            out.stats.backface_culled += 1;
        } else if small && triangles.covers_no_pixel(tri) {
            out.stats.small_culled += 1;
        } else {
            out.indices.extend(t.iter().map(|&i| base + i.into()));
        }
    }
}

/// A back face is hidden only while the eye is outside its closed parts' box, grown by the
/// near plane (which would otherwise cut the front faces away).
fn eye_outside_closed(c: &ClusterRecord, view: &View) -> bool {
    let grow = view.near * 2.0 + view.eye.abs().max_element() * 2.4e-7;
    let lo = DVec3::from(c.closed_min.map(f64::from)) - grow;
    let hi = DVec3::from(c.closed_max.map(f64::from)) + grow;
    !(view.eye.cmpge(lo).all() && view.eye.cmple(hi).all())
}

/// meshopt's cone tests: every triangle of the cluster faces away from the eye when the eye
/// lies in the cone behind the apex, dot(normalize(apex - eye), axis) >= cutoff, or when
/// dot(c - eye, axis) >= cutoff * |c - eye| + radius on the bounding sphere. Each is
/// conservative alone; a margin covers f32 rounding.
fn faces_away(c: &ClusterRecord, center: DVec3, radius: f64, view: &View) -> bool {
    if c.cone_cutoff >= 1.0 {
        return false;
    }
    let axis = DVec3::from(c.cone_axis.map(f64::from));
    let cutoff = c.cone_cutoff as f64 + 1e-4;
    let to_apex = DVec3::from(c.cone_apex.map(f64::from)) - view.eye;
    let d = center - view.eye;
    to_apex.dot(axis) >= cutoff * to_apex.length() || d.dot(axis) >= cutoff * d.length() + radius
}

/// Every triangle of the cluster faces the eye: [`faces_away`]'s sphere test with the cone
/// turned around, as for the same triangles wound the other way.
fn faces_toward(c: &ClusterRecord, center: DVec3, radius: f64, view: &View) -> bool {
    let d = center - view.eye;
    c.cone_cutoff < 1.0 && -d.dot(DVec3::from(c.cone_axis.map(f64::from))) >= (c.cone_cutoff as f64 + 1e-4) * d.length() + radius
}

#[cfg(test)]
mod tests {
    use super::*;
    use osw_scene::Camera;
    use osw_scene::generators::shapes::add_box;
    use osw_scene::mesh::Mesh;

    #[test]
    fn a_list_of_tests_reads_back_what_it_writes() {
        for bits in 0..32u32 {
            let mut t = ClusterTests::NONE;
            for (k, flag) in t.flags().into_iter().enumerate() {
                *flag = bits >> k & 1 == 1;
            }
            let written = t.to_string();
            assert_eq!(written.parse::<ClusterTests>(), Ok(t), "{written}");
        }
        assert_eq!(ClusterTests::default().to_string(), "frustum,cone,backface,small,occlusion");
        assert_eq!("none".parse::<ClusterTests>(), Ok(ClusterTests::NONE));
        for bad in ["", "none,cone", "frustrum", "cone,"] {
            assert!(bad.parse::<ClusterTests>().unwrap_err().contains("expected a list of"), "{bad:?}");
        }
    }

    /// A mask carries exactly the notes of the visible set it was made for: every node looked
    /// at, a node's clusters past 64 included; a node not looked at is drawn whole; a mask of
    /// the wrong length, or with bits past its last cluster, is refused.
    #[test]
    fn a_cluster_mask_reads_back_the_notes_it_was_made_from() {
        let counts = |id: NodeId| [3u32, 0, 70, 5][id as usize];
        let pvs = [0, 1, 2, 3];
        let mut notes = VisibleClusters::default();
        let marked = [(0, 1), (2, 0), (2, 63), (2, 64), (2, 69), (3, 4)];
        for id in pvs {
            notes.look_at(id, counts(id));
            for &(_, k) in marked.iter().filter(|m| m.0 == id) {
                notes.mark(k);
            }
        }
        let mask = notes.mask().to_vec();
        assert_eq!(mask.len(), (3 + 70 + 5usize).div_ceil(8));
        let back = VisibleClusters::from_mask(&pvs, counts, mask.clone()).unwrap();
        for id in pvs {
            for k in 0..counts(id) as usize {
                assert_eq!(back.takes(id, k), marked.contains(&(id, k)), "node {id} cluster {k}");
            }
        }
        assert!(!back.takes(2, 70) && !back.takes(0, 3), "past a node's clusters");
        assert!(back.takes(9, 0), "a node not looked at is drawn whole");
        let short = VisibleClusters::from_mask(&pvs, counts, mask[1..].to_vec()).unwrap_err().to_string();
        assert!(short.contains("of 78 clusters"), "{short}");
        let mut padded = mask.clone();
        *padded.last_mut().unwrap() |= 0x80;
        assert_eq!(VisibleClusters::from_mask(&pvs, counts, padded), Err(MaskError::Padding));
    }

    /// Triangles of `m` whose front faces `eye` (counter-clockwise from outside).
    fn front_facing(m: &Mesh, t: &[u32], eye: DVec3) -> bool {
        let p = |i: u32| DVec3::from(m.positions[i as usize].map(f64::from));
        let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
        (b - a).cross(c - a).dot(eye - a) > 0.0
    }

    /// 400 boxes of many sizes and orientations of faces, clustered (the mesh's indices in
    /// cluster order), and 50 views of them from all around.
    fn boxes() -> (Mesh, Vec<ClusterRecord>, Vec<View>) {
        let mut m = Mesh::default();
        for i in 0..400 {
            let o = glam::Vec3::new((i % 20) as f32 * 3.0, (i / 20) as f32 * 3.0, (i % 7) as f32);
            add_box(&mut m, o, o + glam::Vec3::new(1.0 + (i % 3) as f32, 1.0, 0.5 + (i % 5) as f32));
        }
        let osw_scene::cluster::Clustered { indices, clusters, .. } = osw_scene::cluster::clusterize(&m, None);
        m.indices = indices;
        let views = (0..50)
            .map(|k| {
                let a = k as f64 * 0.7;
                let eye = DVec3::new(30.0 + 90.0 * a.cos(), 30.0 + 40.0 * (a * 0.3).sin(), 90.0 * a.sin());
                View::new(&Camera::look_at(eye, DVec3::new(30.0, 30.0, 2.0), 60.0), DVec3::ZERO, 256, 256, 0.01)
            })
            .collect();
        (m, clusters, views)
    }

    #[test]
    fn no_front_facing_triangle_is_culled_and_back_faces_are() {
        let (m, clusters, views) = boxes();
        let mut culled_total = [0; 2];
        // Triangles the cone test and the triangle test drop.
        for view in &views {
            for tests in [ClusterTests { cone: true, ..ClusterTests::NONE }, ClusterTests { backface: true, ..ClusterTests::NONE }] {
                let mut s = ClusterStats::default();
                let out = draw(view, &m, &clusters, tests, &mut s);
                let kept: std::collections::HashSet<&[u32]> = out.chunks_exact(3).collect();
                for (t, tri) in m.indices.chunks_exact(3).enumerate() {
                    assert!(kept.contains(tri) || !front_facing(&m, tri, view.eye), "front-facing triangle {t} culled from {}", view.eye);
                }
                culled_total[usize::from(tests.backface)] += (m.indices.len() - out.len()) / 3;
            }
            assert!(culled_total[1] >= culled_total[0], "the triangle test drops what the cone test does");
        }
        assert!(culled_total[0] > 0, "boxes seen from outside have back-facing clusters");
    }

    #[test]
    fn a_cluster_said_to_face_the_eye_has_no_back_face() {
        let (m, clusters, views) = boxes();
        let (mut toward, mut away) = (0, 0);
        for view in &views {
            for c in &clusters {
                let center = DVec3::from(c.center.map(f64::from));
                let triangles = cluster_indices(&m.indices, c);
                if faces_toward(c, center, c.radius as f64, view) {
                    toward += 1;
                    assert!(
                        triangles.chunks_exact(3).all(|t| front_facing(&m, t, view.eye)),
                        "a cluster facing {} has a back face",
                        view.eye
                    );
                }
                away += usize::from(faces_away(c, center, c.radius as f64, view));
            }
        }
        assert!(toward > 1000 && away > 1000, "boxes seen from outside: {toward} clusters facing, {away} facing away");
    }

    /// The indices a pass would draw of mesh `m`.
    fn draw(view: &View, m: &Mesh, clusters: &[ClusterRecord], tests: ClusterTests, s: &mut ClusterStats) -> Vec<u32> {
        let mut out = Vec::new();
        gather(view, tests, &m.positions, &m.indices, clusters, &[], &mut Out { indices: &mut out, base: 0, stats: s });
        out
    }

    /// Open boxes (a top missing) of single-sided and of double-sided faces, seen from inside
    /// through the opening: with no tests asked for, every pass still drops the single-sided
    /// back faces, and only those; the double-sided ones are all drawn.
    #[test]
    fn single_sided_back_faces_are_dropped_whatever_the_tests() {
        let open_box = |single: bool| {
            let mut m = Mesh::default();
            add_box(&mut m, glam::Vec3::ZERO, glam::Vec3::splat(10.0));
            let top = |t: &[u32]| t.iter().all(|&v| m.positions[v as usize][1] == 10.0);
            m.indices = m.indices.chunks_exact(3).filter(|t| !top(t)).flatten().copied().collect();
            m.single_sided = vec![single; m.positions.len()];
            let osw_scene::cluster::Clustered { indices, clusters, .. } = osw_scene::cluster::clusterize(&m, None);
            m.indices = indices;
            (m, clusters)
        };
        // Beside and above: the outside of the near wall faces the eye; through the opening,
        // the insides of the far walls and of the floor are back faces.
        let view = View::new(&Camera::look_at(DVec3::new(30.0, 25.0, 5.5), DVec3::splat(5.0), 60.0), DVec3::ZERO, 64, 64, 0.01);
        for single in [true, false] {
            let (m, clusters) = open_box(single);
            assert!(clusters.iter().all(|c| c.single_sided() == single));
            let mut s = ClusterStats::default();
            let out = draw(&view, &m, &clusters, ClusterTests::NONE, &mut s);
            let away = m.indices.chunks_exact(3).filter(|t| !front_facing(&m, t, view.eye)).count();
            assert!(away > 0 && away < m.indices.len() / 3, "the box turns some faces away and some not");
            let kept: Vec<&[u32]> = out.chunks_exact(3).collect();
            if single {
                assert_eq!(kept.len(), m.indices.len() / 3 - away, "{s:?}");
                assert!(kept.iter().all(|t| front_facing(&m, t, view.eye)));
            } else {
                assert_eq!(out, m.indices, "every triangle, in cluster order");
            }
        }
    }

    #[test]
    fn the_eye_inside_a_closed_part_turns_the_back_face_tests_off() {
        let mut m = Mesh::default();
        add_box(&mut m, glam::Vec3::ZERO, glam::Vec3::splat(10.0));
        let osw_scene::cluster::Clustered { indices, clusters, .. } = osw_scene::cluster::clusterize(&m, None);
        m.indices = indices;
        let view = View::new(&Camera::look_at(DVec3::splat(5.0), DVec3::new(5.0, 5.0, 0.0), 60.0), DVec3::ZERO, 64, 64, 0.01);
        let mut s = ClusterStats::default();
        let out = draw(&view, &m, &clusters, ClusterTests { cone: true, backface: true, ..ClusterTests::NONE }, &mut s);
        assert_eq!((s.cone_culled, s.backface_culled), (0, 0));
        assert_eq!(out, m.indices, "every triangle, in cluster order");
    }

    #[test]
    fn spheres_behind_the_eye_are_frustum_culled() {
        let c =
            |x: f32| ClusterRecord { center: [x, 0.0, 0.0], radius: 1.0, cone_cutoff: 2.0, index_count: 3, ..bytemuck::Zeroable::zeroed() };
        let clusters = [c(-10.0), c(10.0)];
        let clusters = [ClusterRecord { first_index: 3, ..clusters[1] }, clusters[0]];
        let view = View::new(&Camera::look_at(DVec3::ZERO, DVec3::X, 60.0), DVec3::ZERO, 64, 64, 0.01);
        let m = Mesh { indices: vec![0, 1, 2, 3, 4, 5], ..Default::default() };
        let mut s = ClusterStats::default();
        let out = draw(&view, &m, &clusters, ClusterTests { frustum: true, ..ClusterTests::NONE }, &mut s);
        assert_eq!((s.clusters, s.frustum_culled), (2, 1));
        assert_eq!(out, vec![3, 4, 5]);
    }
}
