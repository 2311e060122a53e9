//! OR, the occluder pass (occlusion switch sec. 4.6): the last visible set, re-selected for the
//! newest camera, drawn into the depth buffer that HC tests against.

use osw_cull::View;
use osw_cull::cluster::VisibleClusters;
use osw_cull::front::update_front;
use osw_cull::hzb::{Pyramid, Read, visible_box};
use osw_gpu::draw::{Layer, Load, Pass};
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
    /// HC's notes of the frame that found `ids`: only the clusters they take are drawn (paper
    /// 004 sec. 5.3.1: the clusters visible in the last frame are the occluders; see
    /// [`note_clusters`]).
    pub notes: Option<&'a VisibleClusters>,
}

/// Draws the opaque clusters of `occ` re-selected for `view` (the front update of sec. 4.6)
/// into the depth buffer. `front` is scratch space kept across frames.
pub fn or(r: &mut Renderer, scene: &SceneFile, view: &View, occ: Occluders, front: &mut Vec<NodeId>) -> Result<DrawStats, RenderError> {
    update_front(scene.nodes(), occ.ids, view, occ.tau, front);
    let Some(notes) = occ.notes else { return r.draw_opaque(scene, view, front, Pass::Depth, occ.load) };
    let mut drawn = r.gather(scene, view, front, r.options().cluster_tests, Some(&mut |id, k| notes.takes(id, k)))?;
    r.submit(view, Pass::Depth, Layer::Opaque, occ.load, &mut drawn)?;
    Ok(drawn)
}

/// The opaque clusters of `pvs` (HC's V(i), sorted, for `view`) that `pyramid` does not hide
/// on the image. RVG of this frame draws only those: a hidden cluster is behind geometry drawn
/// for this camera (OR's occluders and HC's, each at tau for it), and the node nearest at each
/// pixel is in the visible set with its nearest cluster, so the image is the visible set's. OR,
/// drawing V(i) as occluders for a later camera, draws only those too: a hidden cluster writes
/// no depth, and one still hidden a frame or two later writes none either (the temporal
/// coherence that sec. 4.6 draws V(i-1) on). Fewer occluders can only make HC find more
/// visible: conservative. Clusters at the frustum's edge, hidden on the image, were kept for
/// OR at first (they may come into view for its later camera): they changed almost no PVS
/// and cost OR time (docs/measurements/2026-12-07-constants.md, "note_clusters").
/// A cluster the cut does not take for this camera is noted as one not looked at, drawn: when
/// the camera nears a surface its cut node keeps its id and takes finer clusters, which OR two
/// frames later draws as occluders as it draws a static LOD chosen anew (any geometry of the
/// cut for its camera is a fair occluder); RVG of this frame never draws it.
pub fn note_clusters(scene: &SceneFile, view: &View, pvs: &[NodeId], pyramid: &Pyramid) -> Result<VisibleClusters, RenderError> {
    let vp = view.view_proj().as_dmat4();
    let mut notes = VisibleClusters::default();
    for &id in pvs {
        // An instance's cluster boxes placed, not its vertices: a placed box holds the placed
        // cluster's box (exactly where the placement keeps the axes), so the test is conservative.
        let (g, placement) = (scene.stored_geometry(id)?, scene.placement(id));
        notes.look_at(id, g.opaque as u32);
        for (k, c) in g.clusters[..g.opaque].iter().enumerate() {
            if !view.lod.takes(&c.cut) {
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
