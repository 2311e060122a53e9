//! osw culling: the per-frame visibility algorithms as plain synchronous code over a
//! [`VisibilityTester`], so that they run and are tested without a GPU.
//!
//! - [`view`]: a camera turned into what culling needs (scene-local eye, frustum, focal length).
//! - [`frustum`]: view-frustum tests of node boxes.
//! - [`tester`]: the visibility-test interface (GPU implementations live in `osw-gpu`).
//! - [`hc`]: the hardware cull traversal, occlusion switch alg. 4.1 with level batches (sec. 4.7.1)
//!   and the pixel-count LOD stop (sec. 4.7.2).
//! - [`ovc`], [`chc`], [`hzb`]: the baselines of Bartz 1999, CHC and Peng 2014 (depth-ordered
//!   interleaved culling with adaptive culling and a budget, which without them is CHC's paper's
//!   stop-and-wait; coherent hierarchical culling; a software Z pyramid).
//! - [`cluster`]: frustum and back-face cone tests of the clusters inside a node drawn.
//! - [`triangle`]: back-face and small-triangle tests of the triangles of a cluster drawn.
//! - [`delta`]: visible-set deltas, V(i) = (V(i-1) - removed) ∪ added (occlusion switch sec. 3.4).
//! - [`states`]: nodes classified visible / frustum-culled / occlusion-culled, for display.
//! - [`front`]: the front update that re-selects last frame's visible set for a new camera
//!   (occlusion switch sec. 4.6), used to draw occluders.

pub mod chc;
pub mod cluster;
pub mod delta;
pub mod distance_queue;
mod fault;
pub mod front;
pub mod frustum;
pub mod gathered;
pub mod hc;
pub mod hzb;
pub mod ovc;
pub mod payoff;
pub mod retest;
pub mod states;
pub mod tester;
pub mod triangle;
pub mod view;

pub use hc::{HcStats, frustum_cull, hardware_cull, hardware_cull_from, hardware_cull_seen};
pub use tester::{AllVisible, Occluders, Visibility, VisibilityTester};
pub use view::View;
