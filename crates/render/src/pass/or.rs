//! OR, the occluder pass (occlusion switch sec. 4.6): the last visible set, re-selected for the
//! newest camera, drawn into the depth buffer that HC tests against.

use osw_cull::View;
use osw_cull::cluster::VisibleClusters;
use osw_cull::front::update_front;
use osw_cull::hzb::{Pyramid, Read, visible_box};
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{DrawStats, RenderError, Renderer};
use osw_scene::{NodeId, SceneFile};

/// What OR draws (occlusion switch sec. 4.6): a visible set re-selected for the newest camera.
pub struct Occluders<'a> {
    /// The front of V(i-2), or HC's additions of frame i-1 as they arrive: HC chose those for
    /// camera i-1, so they are re-selected too and every occluder is geometry at tau for
    /// camera i (tau may also change between frames).
    pub ids: &'a [NodeId],
    pub tau: f64,
    /// [`Load::Clear`] starts a new depth buffer, [`Load::Keep`] draws into the one there is.
    pub load: Load,
}

/// Draws the opaque clusters of `occ` re-selected for `view` (the front update of sec. 4.6)
/// into the depth buffer, whole: HC's notes of the clusters hidden when `occ` was found
/// ([`note_clusters`]) are RVG's, not OR's. OR's camera is two frames later than the notes',
/// and a cluster hidden behind a silhouette then shows a sliver beside it; left out, it leaves
/// a hole in the depth buffer there, through which HC's tests see every box behind
/// (Peng 2014's pyramid and the exact test alike), and HC tests deeper into what the hole
/// shows (docs/measurements/2026-12-07-hc-walks.md). `front` is scratch space kept across
/// frames.
pub fn or(r: &mut Renderer, scene: &SceneFile, view: &View, occ: Occluders, front: &mut Vec<NodeId>) -> Result<DrawStats, RenderError> {
    update_front(scene.nodes(), occ.ids, view, occ.tau, front);
    r.draw_opaque(scene, view, front, Pass::Depth, occ.load)
}

/// The opaque clusters of `pvs` (HC's V(i), sorted, for `view`) that `pyramid` does not hide
/// on the image. RVG of this frame draws only those: a hidden cluster is behind geometry drawn
/// for this camera (OR's occluders and HC's, each at tau for it), and the node nearest at each
/// pixel is in the visible set with its nearest cluster, so the image is the visible set's.
/// A cluster the cut does not take for this camera is not looked at (marked): RVG's own cut
/// for this camera leaves it out.
pub fn note_clusters(scene: &SceneFile, view: &View, pvs: &[NodeId], pyramid: &Pyramid) -> Result<VisibleClusters, RenderError> {
    let vp = view.view_proj().as_dmat4();
    let mut notes = VisibleClusters::default();
    for &id in pvs {
        // An instance's cluster boxes placed, not its vertices: a placed box holds the placed
        // cluster's box (exactly where the placement keeps the axes), so the test is conservative.
        let (g, placement) = (scene.stored_geometry(id)?, scene.placement(id));
        notes.look_at(id, g.opaque as u32);
        for (k, c) in g.clusters[..g.opaque].iter().enumerate() {
            if !view.lod.takes(g.cut(k)) {
                notes.mark(k);
                continue;
            }
            let b = placement.as_ref().map_or(c.aabb(), |p| p.bounds(c.aabb()));
            // The part of the box on the image is tested: hidden there, it is hidden.
            if view.frustum.needs_no_test(&b) || visible_box(pyramid, &vp, view, &b, Read::at(CLUSTER_FINER)) {
                notes.mark(k);
            }
        }
    }
    Ok(notes)
}

/// The note reads the pyramid this many levels finer than Peng 2014's 2x2 texels: a box spans
/// at most 64 texels a side. On the 5M plant walk at tau 5, as RVG's own test, 2 levels left
/// 10,246 of 13,451 triangles a frame, 5 levels 8,960 (docs/measurements/2026-12-02-clusters.md).
const CLUSTER_FINER: u32 = 5;
