//! What a run was made from: a report or a sweep reuses a run (and exact visibility, whose
//! `input.json` says it) only when this is the same.

use super::Summary;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Input {
    pub scene_hash: String,
    pub path: String,
    pub width: u32,
    pub height: u32,
}

impl Input {
    pub fn of(s: &Summary) -> Input {
        Input { scene_hash: s.scene_hash.clone(), path: s.path.clone(), width: s.width, height: s.height }
    }
}
