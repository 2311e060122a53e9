//! Exact visibility per frame (`osw exact`: `exact.csv`), read by `osw compare` and `osw
//! report` as the reference of culling error.

use serde::{Deserialize, Serialize};

/// One frame of exact visibility: the leaves and triangles visible in the item buffer, the
/// triangles of the clusters holding them (the floor of cluster culling; empty when unknown),
/// and the triangles it drew.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct ExactFrame {
    pub frame: u64,
    pub visible_leaves: u64,
    pub visible_triangles: u64,
    pub visible_cluster_triangles: Option<u64>,
    pub drawn_triangles: u64,
}
