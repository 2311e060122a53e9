//! osw GPU renderer on wgpu (Vulkan; Mesa lavapipe when there is no GPU).
//!
//! - [`device`]: adapter choice and device set-up, with a clear error when there is no driver.
//! - [`residency`]: geometry uploaded on first use from the mapped scene into one vertex arena,
//!   each mesh once however many nodes use it, under an LRU budget.
//! - [`atlas`]: the scene's textures, every level of every image packed into one texture
//!   array, and where each texture's levels lie.
//! - [`uses`]: a pass's nodes, each with its mesh in the arena and its instance's placement.
//! - [`target`]: the offscreen colour, depth and item-buffer attachments and their readback.
//! - [`draw`]: drawing a set of LOD nodes (colour for RVG, depth only for OR, item ids for
//!   exact visibility).
//! - [`boxtest`]: the HC primitive: node boxes tested against the depth buffer (occlusion switch
//!   sec. 4.2), exact per pixel with forced early depth, optionally counting pixels (4.7.2).
//! - [`pyramid`]: the fast HC test: a farthest-depth pyramid and a compute box test.
//! - [`exact`]: item-buffer exact visibility (occlusion switch sec. 5) for verification.
//! - [`renderer`]: the above for one scene and one image size: index lists submitted, boxes tested.
//! - [`gather`]: a pass's index list from its nodes' clusters, less what their tests drop.
//! - [`testers`]: the renderer as HC's visibility tester.

pub mod atlas;
pub mod boxtest;
pub mod device;
pub mod draw;
pub mod exact;
pub mod gather;
pub mod limits;
pub mod pyramid;
mod ranges;
pub mod readback;
pub mod renderer;
pub mod residency;
pub mod shaders;
pub mod target;
pub mod testers;
pub mod uses;

pub use device::{Gpu, GpuError};
pub use renderer::{RenderOptions, Renderer};
