//! The visibility-test interface the traversals use. Implementations test node boxes against
//! an occluder depth buffer (GPU: `osw-gpu`) or answer from a fixed set (tests).

use crate::view::View;
use osw_scene::NodeId;

/// The answer for one box.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Visibility {
    /// Some part of the box passes the depth test: conservative (never false when any
    /// geometry inside could be visible).
    pub visible: bool,
    /// Pixels of the box that pass, when the tester counts them (occlusion switch sec. 4.7.2).
    pub pixels: Option<u32>,
}

pub trait VisibilityTester {
    /// Why a test could not be made (a GPU's error); the traversal stops and returns it.
    /// [`std::convert::Infallible`] for a tester that cannot fail.
    type Error;

    /// Tests the boxes of BVH nodes `ids` for `view`; appends one answer per id to `out`, in
    /// order. One call is one batch: occlusion switch sec. 4.7.1 issues a whole level at once.
    fn test(&mut self, view: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error>;

    /// Offered after each round but the last: LODs of this frame's PVS not in V(i-1) (OR drew
    /// nothing of them), found since the last ones taken. A tester may add them as occluders
    /// for the rest of the traversal (now, or with later ones) and returns whether it took
    /// them; else they are offered again with the next ones. Conservative: they are the scene's geometry at tau for this view,
    /// and hide only what is behind them.
    fn add_occluders(&mut self, _view: &View, _lods: &[NodeId]) -> Result<bool, Self::Error> {
        Ok(false)
    }

    /// Whether an answer costs an occlusion test (counted in the statistics).
    fn tests(&self) -> bool {
        true
    }
}

/// A tester that also draws: the interleaved traversals of CHC's paper (S&W, CHC) draw visible
/// nodes into the occluder depth buffer as they find them.
pub trait Occluders: VisibilityTester {
    /// Adds LOD nodes to the occluder depth buffer; every test issued afterwards sees them.
    fn render(&mut self, lods: &[NodeId]) -> Result<(), Self::Error>;
}

/// Frustum culling only: every box that reaches the tester is visible.
pub struct AllVisible;

impl VisibilityTester for AllVisible {
    type Error = std::convert::Infallible;

    fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error> {
        out.extend(ids.iter().map(|_| Visibility { visible: true, pixels: None }));
        Ok(())
    }

    fn tests(&self) -> bool {
        false
    }
}
