//! Budgets of the GPU crate, each with its reason.

/// Default geometry residency budget: 1 GiB holds a 20M-triangle scene's vertices at all its
/// LODs (an `ArenaVertex` each: position and colour) several times over; lavapipe's "GPU memory" is
/// host memory, so the budget is what keeps a process's footprint bounded.
pub const RESIDENCY_BYTES: u64 = 1 << 30;

/// Most boxes in one test batch; sizes the box and result buffers (a `GpuBox` and a u32 each).
/// A level of the BVH larger than this is tested in several batches.
pub const MAX_BOXES: u32 = 1 << 18;

/// Image sizes accepted (pixels a side): wgpu's guaranteed 2D texture limit.
pub const MAX_SIZE: u32 = 8192;
