//! Front-to-back order for the hierarchical traversals of CHC's paper (S&W and CHC): nodes pop
//! nearest first, by the distance from the eye to their box.

use glam::DVec3;
use osw_scene::error_metric::distance_to_box;
use osw_scene::{NodeId, NodeRecord};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

pub struct DistanceQueue {
    heap: BinaryHeap<Reverse<(u64, NodeId)>>,
}

impl DistanceQueue {
    pub fn new() -> DistanceQueue {
        DistanceQueue { heap: BinaryHeap::new() }
    }

    pub fn push(&mut self, nodes: &[NodeRecord], eye: DVec3, id: NodeId) {
        // Non-negative f64 bits order like the numbers; ties break by id (deterministic).
        let d = distance_to_box(eye, &nodes[id as usize].aabb());
        self.heap.push(Reverse((d.to_bits(), id)));
    }

    pub fn pop(&mut self) -> Option<NodeId> {
        self.heap.pop().map(|Reverse((_, id))| id)
    }

    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
}

impl Default for DistanceQueue {
    fn default() -> Self {
        DistanceQueue::new()
    }
}
