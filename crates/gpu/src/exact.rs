//! Exact visibility by item buffer (paper 000 sec. 5): every leaf in the frustum drawn at full
//! detail with its id and each triangle's index; the ids left in the image are exactly the
//! visible leaves and triangles at this resolution.

use crate::draw::Pass;
use crate::renderer::{RenderError, Renderer};
use osw_cull::View;
use osw_cull::frustum::Containment;
use osw_scene::NodeId;
use osw_scene::format::NodeKind;

/// Exact visibility of one frame.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ExactFrame {
    /// Visible leaves (BVH node ids), sorted.
    pub leaves: Vec<NodeId>,
    /// Distinct visible triangles.
    pub triangles: u64,
}

impl Renderer {
    pub fn exact(&mut self, view: &View) -> Result<ExactFrame, RenderError> {
        let scene = std::sync::Arc::clone(&self.scene);
        let level0: Vec<NodeId> = (0..scene.bvh_count())
            .map(|id| scene.node(id))
            .filter(|n| n.kind() == NodeKind::Leaf && view.frustum.classify(&n.aabb()) != Containment::Outside)
            .map(|n| n.first_lod)
            .collect();
        self.draw(view, &level0, Pass::Item, true)?;
        let mut items: Vec<[u32; 2]> = self.target.read_item(&self.gpu)?.into_iter().filter(|i| i[0] != 0).collect();
        items.sort_unstable();
        items.dedup();
        let mut leaves: Vec<NodeId> = items.iter().map(|i| scene.node(i[0] - 1).parent).collect();
        leaves.dedup();
        Ok(ExactFrame { leaves, triangles: items.len() as u64 })
    }
}
