//! Coherent hierarchical culling (CHC fig. 2), the `chc` baseline. Nodes visible last
//! frame are drawn without waiting (leaves) or opened without a test (interior nodes); every
//! other node in the frustum is queried, and the traversal goes on while queries are in
//! flight; a query that returns visible pulls visibility up to the root and resumes the
//! traversal below the node.
//!
//! Adapted to wgpu's readback: queries are issued in batches and a batch's answers become
//! available when it is flushed: when the distance queue runs dry (the paper's "wait"), or
//! when BATCH queries are pending. Draws issued before a batch are in the depth buffer it
//! tests against.

use crate::distance_queue::DistanceQueue;
use crate::frustum::Containment;
use crate::hc::HcStats;
use crate::tester::{Occluders, Visibility};
use crate::view::{Cut, View};
use osw_scene::error_metric::select;
use osw_scene::{NodeId, NodeRecord};

/// Largest batch of queries in flight before the traversal waits for them.
const BATCH: usize = 256;

/// Per-node visibility kept between frames.
pub struct ChcState {
    visible: Vec<bool>,
    last_visited: Vec<u64>,
    frame: u64,
}

impl ChcState {
    /// State for a scene of `bvh_count` BVH nodes; nothing is visible before the first frame.
    pub fn new(bvh_count: u32) -> ChcState {
        ChcState { visible: vec![false; bvh_count as usize], last_visited: vec![0; bvh_count as usize], frame: 0 }
    }

    /// Runs one frame of CHC for `view` at `tau`; appends the PVS to `pvs`.
    pub fn frame<E>(
        &mut self,
        nodes: &[NodeRecord],
        view: &View,
        tau: f64,
        occ: &mut dyn Occluders<Error = E>,
        pvs: &mut Vec<NodeId>,
    ) -> Result<HcStats, E> {
        self.frame += 1;
        let mut stats = HcStats::default();
        let mut queue = DistanceQueue::new();
        queue.push(nodes, view.eye, 0);
        // Queries in flight: node and whether it was visible last frame (then it is already
        // drawn or opened, and a visible answer only pulls visibility up).
        let (mut pending, mut answers): (Vec<(NodeId, bool)>, Vec<Visibility>) = (Vec::new(), Vec::new());
        let mut ids = Vec::new();
        while !queue.is_empty() || !pending.is_empty() {
            if !pending.is_empty() && (queue.is_empty() || pending.len() >= BATCH) {
                answers.clear();
                ids.clear();
                ids.extend(pending.iter().map(|p| p.0));
                occ.test(view, &ids, &mut answers)?;
                stats.levels += 1;
                for (&(id, was_visible), a) in pending.iter().zip(&answers) {
                    if a.visible {
                        self.pull_up(nodes, id);
                        if !was_visible {
                            self.traverse(Cut { nodes, view, tau }, id, occ, &mut queue, pvs)?;
                        }
                    } else {
                        stats.occlusion_culled += 1;
                        stats.culled_triangles += nodes[id as usize].triangles;
                    }
                }
                pending.clear();
            }
            let Some(id) = queue.pop() else { continue };
            let b = nodes[id as usize].aabb();
            if view.frustum.classify(&b) == Containment::Outside {
                stats.frustum_culled += 1;
                continue;
            }
            let i = id as usize;
            let was_visible = self.visible[i] && self.last_visited[i] == self.frame - 1;
            let terminal = !select(nodes, id, &view.lod_at(tau)).refine;
            let opened = was_visible && !terminal;
            self.visible[i] = false;
            self.last_visited[i] = self.frame;
            if view.frustum.needs_no_test(&b) {
                // Cannot be queried: visible now.
                stats.untested += 1;
                self.pull_up(nodes, id);
                self.traverse(Cut { nodes, view, tau }, id, occ, &mut queue, pvs)?;
                continue;
            }
            if !opened {
                pending.push((id, was_visible));
                stats.tests += 1;
            }
            if was_visible {
                self.traverse(Cut { nodes, view, tau }, id, occ, &mut queue, pvs)?;
            }
        }
        pvs.sort_unstable();
        pvs.dedup();
        Ok(stats)
    }

    fn pull_up(&mut self, nodes: &[NodeRecord], mut id: NodeId) {
        while !self.visible[id as usize] {
            self.visible[id as usize] = true;
            match nodes[id as usize].parent {
                u32::MAX => break,
                p => id = p,
            }
        }
    }

    /// Draws a node that meets tau (the paper's leaves), else queues its children (both for a
    /// cluster hierarchy's node).
    fn traverse<E>(
        &self,
        cut: Cut,
        id: NodeId,
        occ: &mut dyn Occluders<Error = E>,
        queue: &mut DistanceQueue,
        pvs: &mut Vec<NodeId>,
    ) -> Result<(), E> {
        let Cut { nodes, view, tau } = cut;
        let s = select(nodes, id, &view.lod_at(tau));
        if let Some(lod) = s.draw {
            occ.render(&[lod])?;
            pvs.push(lod);
        }
        if s.refine {
            nodes[id as usize].children().for_each(|c| queue.push(nodes, view.eye, c));
        }
        Ok(())
    }
}
