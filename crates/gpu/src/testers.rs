//! The renderer as HC's [`VisibilityTester`]: node boxes tested on the GPU, and for the
//! interleaved traversals (S&W, CHC) the nodes found visible drawn as occluders in between.

use crate::draw::{Load, Pass};
use crate::renderer::{BoxTest, RenderError, Renderer, Sampling};
use osw_cull::{Occluders, View, Visibility, VisibilityTester};
use osw_scene::{NodeId, SceneFile};

/// A [`VisibilityTester`] on the GPU box test; a GPU error ends the traversal with it.
pub struct GpuTester<'a> {
    pub renderer: &'a mut Renderer,
    pub scene: &'a SceneFile,
    pub test: BoxTest,
    pub sampling: Sampling,
}

impl<'a> GpuTester<'a> {
    /// Tests with `test`, reading every pixel line.
    pub fn new(renderer: &'a mut Renderer, scene: &'a SceneFile, test: BoxTest) -> GpuTester<'a> {
        GpuTester { renderer, scene, test, sampling: Sampling::EVERY_LINE }
    }
}

impl VisibilityTester for GpuTester<'_> {
    type Error = RenderError;

    fn test(&mut self, view: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), RenderError> {
        let boxes = ids.iter().map(|&id| self.scene.node(id).aabb());
        self.renderer.test_boxes(view, boxes, self.test, self.sampling, out)
    }
}

/// An [`Occluders`] tester for the interleaved traversals: nodes to draw are collected and
/// drawn depth-only into the occluder buffer right before the next test, so every test sees
/// everything drawn before it was issued, in as few submissions as possible.
pub struct InterleavedTester<'a> {
    pub tester: GpuTester<'a>,
    pending: Vec<NodeId>,
}

impl<'a> InterleavedTester<'a> {
    pub fn new(tester: GpuTester<'a>) -> InterleavedTester<'a> {
        InterleavedTester { tester, pending: Vec::new() }
    }

    /// Draws what is still pending.
    pub fn finish(mut self, view: &View) -> Result<(), RenderError> {
        self.flush(view)
    }

    fn flush(&mut self, view: &View) -> Result<(), RenderError> {
        if !self.pending.is_empty() {
            let t = &mut self.tester;
            t.renderer.draw(t.scene, view, &self.pending, Pass::Depth, Load::Keep)?;
        }
        self.pending.clear();
        Ok(())
    }
}

impl VisibilityTester for InterleavedTester<'_> {
    type Error = RenderError;

    fn test(&mut self, view: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), RenderError> {
        self.flush(view)?;
        self.tester.test(view, ids, out)
    }
}

impl Occluders for InterleavedTester<'_> {
    fn render(&mut self, lods: &[NodeId]) -> Result<(), RenderError> {
        self.pending.extend_from_slice(lods);
        Ok(())
    }
}
