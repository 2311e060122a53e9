//! Limits and budgets of the scene build and the scene file, each with its reason.

/// Default largest number of triangles in one chunk (crate::chunk). 4096 triangles keep a chunk's vertices under 65,536 so its indices fit in u16, and
/// give the hardware cull a box every few thousand triangles: fine enough to cull, coarse enough
/// that the 5M-triangle plant has 9,001 leaves before loose splits (12,821 after).
pub const CHUNK_TRIANGLES: u32 = 4096;

/// A chunk is split in two where the boxes of its halves have less than this fraction of its
/// box's surface area (halving a cube gives 4/3 of it, halving a plane 1): elbowed pipe runs,
/// railings around corners. Measured on the 5M plant, 100-frame walk, tau 5 (prev): 0.5 / 0.7 /
/// 0.85 give 9,715 / 12,821 / 14,143 chunks (9,001 unsplit) and PVS/exact leaves 1.43 / 1.29 /
/// 1.28 (1.45 unsplit), triangles drawn 78,650 / 74,777 / 73,318 (79,064).
pub const LOOSE_SPLIT: f32 = 0.7;

/// Fewest triangles in a chunk made by a loose split: below it a box and a draw cost more than
/// the fit gains.
pub const LOOSE_MIN_TRIANGLES: u32 = 64;

/// A LOD level is kept only if it has at most this fraction of the previous level's triangles.
/// A level that cuts less costs memory and a node id and saves under a third of the draw.
pub const LOD_MIN_REDUCTION: f32 = 0.7;

/// Each LOD level aims at this fraction of the previous level's triangles (the usual factor of
/// 4 between levels: one level per halving of the screen size of the object).
pub const LOD_TARGET_RATIO: f32 = 0.25;

/// Meshes with at most this many triangles get no simplified LOD: a coarser level would save
/// almost nothing and cost a node id and its selection.
pub const LOD_MIN_TRIANGLES: u32 = 32;

/// Most input triangles whose LODs, HLODs and blocks the build makes in memory at once (one
/// subtree, see [`crate::build`]). The build holds about 50 bytes per triangle of a subtree
/// (chains, HLOD inputs and encoded blocks), so 4M keeps that near 200 MB while a subtree's
/// thousand-odd chunks still keep both cores busy.
pub const BUCKET_TRIANGLES: u64 = 4_000_000;

/// Most LOD levels per leaf (the original counts as level 0).
pub const LOD_MAX_LEVELS: usize = 8;

/// An HLOD is kept only if it has at most this fraction of the triangles of drawing its
/// children's coarsest representations; otherwise descending costs little more.
pub const HLOD_MAX_FRACTION: f32 = 0.5;

/// Most triangles in one HLOD: an HLOD is drawn as one block, as a chunk is.
pub const HLOD_MAX_TRIANGLES: u32 = 4 * CHUNK_TRIANGLES;

/// Smallest error given to any simplified level, relative to the scene's extent. A simplified
/// level must never report exactly 0, so that tau = 0 always selects full detail.
pub const MIN_RELATIVE_ERROR: f32 = 1e-7;

/// Most nodes in a scene file: node ids are u32 and u32::MAX marks "none".
pub const MAX_NODES: u32 = u32::MAX - 1;

/// Most vertices of one geometry block (a chunk LOD or an HLOD); u32 indices.
pub const MAX_BLOCK_VERTICES: u32 = 1 << 26;

/// Alignment of each geometry block in the file, so every block starts on its own cache line
/// and positions can be read in place as `[f32; 3]`.
pub const BLOCK_ALIGN: u64 = 64;
