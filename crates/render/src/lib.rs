//! osw single-process rendering: the per-frame algorithm of every culling mode on one GPU, so
//! that every method runs in the same renderer on the same scene and camera path.
//!
//! - [`mode`]: the modes and their per-frame algorithms.
//! - [`pass`]: the frame's named passes, OR, HC and RVG, shared by prev, the nodes and the
//!   display.
//! - [`stats`]: per-frame statistics of a run on one GPU.
//! - [`results`]: the run results every tool writes and reads (`summary.json`, the CSVs).
//! - [`output`]: frame PNGs and the per-frame PVS / exact-visibility files.
//! - [`settings`]: the settings the switch's three processes agree on.
//! - [`run`]: the loops over a camera path for `osw render` and `osw exact`.
//! - [`log`]: the binaries' logging set-up; [`packet`]: the camera as the wire carries it.

pub mod compare;
pub mod log;
pub mod mode;
pub mod output;
pub mod packet;
pub mod pass;
pub mod popping;
pub mod results;
pub mod run;
pub mod settings;
pub mod stats;

pub use mode::Mode;
pub use results::Summary;
pub use stats::FrameStats;
