//! Exact visibility per frame (`osw exact`: `exact.csv`), read by `osw compare` and `osw
//! report` as the reference of culling error.

use serde::{Deserialize, Serialize};

/// One frame of exact visibility: the leaves and triangles visible in the item buffer, the
/// triangles of the clusters holding them (the floor of cluster culling; empty when unknown),
/// the triangles it drew, and the time drawing only the visible ones, or their clusters, takes.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct ExactFrame {
    pub frame: u64,
    pub visible_leaves: u64,
    pub visible_triangles: u64,
    pub visible_cluster_triangles: Option<u64>,
    pub drawn_triangles: u64,
    /// Milliseconds to draw only the visible triangles in colour: RVG's floor (empty when
    /// unknown, as for `visible_cluster_triangles`; missing in files of older versions).
    pub visible_draw_ms: Option<f64>,
    /// The same for the triangles of `visible_cluster_triangles`: culling whole clusters' floor.
    pub visible_cluster_draw_ms: Option<f64>,
}
