//! The frame as named passes, shared by `prev` (one GPU), the switch's nodes and its display
//! (occlusion switch alg. 4.2), each returning what it did:
//!
//! - [`or()`]: OR, the last visible set's front drawn into the depth buffer for the new camera;
//! - [`hc()`]: HC, in three passes, each timed: the traversal against that depth, the
//!   hybrid's second look at small boxes, and the retest of additions drawn as occluders;
//! - [`rvg()`]: RVG, the visible set drawn in colour; in prev over the depth OR and HC left.

mod hc;
mod or;
mod rvg;

pub use hc::{HcOptions, HcPass, HcTest, HcTimes, NEW_OCCLUDERS_MIN, hc};
pub use or::{Occluders, note_clusters, or};
pub use rvg::rvg;
