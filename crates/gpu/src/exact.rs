//! Exact visibility by item buffer (paper 000 sec. 5): the scene as frustum culling draws it at
//! tau, each LOD node with its id and each triangle's index; the ids left in the image are
//! exactly the visible nodes and triangles at this resolution. At tau 0 that is every leaf in
//! the frustum at full detail (the paper's reference); at tau > 0 it is the image a person sees
//! at that tau, so that culling error can be told apart from LOD error.

use crate::draw::Pass;
use crate::renderer::{RenderError, Renderer};
use osw_cull::{AllVisible, View, hardware_cull};
use osw_scene::NodeId;

/// Exact visibility of one frame.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ExactFrame {
    /// BVH nodes whose geometry is visible, sorted: leaves, and at tau > 0 also groups shown
    /// by their HLOD.
    pub leaves: Vec<NodeId>,
    /// Distinct visible triangles.
    pub triangles: u64,
}

impl Renderer {
    pub fn exact(&mut self, view: &View, tau: f64) -> Result<ExactFrame, RenderError> {
        let scene = std::sync::Arc::clone(&self.scene);
        let mut front = Vec::new();
        hardware_cull(scene.nodes(), view, tau, &mut AllVisible, &mut front);
        // Sorted: where two surfaces tie in depth the first drawn keeps the pixel.
        front.sort_unstable();
        self.draw(view, &front, Pass::Item, true)?;
        let mut items: Vec<[u32; 2]> = self.target.read_item(&self.gpu)?.into_iter().filter(|i| i[0] != 0).collect();
        items.sort_unstable();
        items.dedup();
        let mut leaves: Vec<NodeId> = items.iter().map(|i| scene.node(i[0] - 1).parent).collect();
        leaves.sort_unstable();
        leaves.dedup();
        Ok(ExactFrame { leaves, triangles: items.len() as u64 })
    }
}
