//! The peer's messages in arrival order, each with the display's path it belongs to.
//!
//! A restarted display (RVG) connects to both nodes, and each starts over when its own
//! connection says so: the peer may still send frames of the old path after this node started
//! over, or frames of the new path before. Each node counts the display restarts it started
//! over for (its run) and tells the peer with a `StartOver` ahead of its first message of the
//! new path; TCP keeps the order, so every message is known to belong to a run, and is used in
//! that run only. Counts start afresh with each connection to the peer.

use osw_wire::messages::{Message, StartOver};
use std::collections::VecDeque;

#[derive(Default)]
pub struct PeerQueue {
    /// (run, message, arrival time).
    messages: VecDeque<(u64, Message, u64)>,
    /// Display restarts seen (connections after the first).
    restarts: u64,
    /// The restarts this node started over for.
    run: u64,
    /// The run the peer's messages belong to now, in this node's count.
    peer_run: u64,
    /// `run` when the peer was last told.
    told: u64,
}

impl PeerQueue {
    /// A new connection to the peer: what the old one brought is stale, and both ends count
    /// from here.
    pub fn connected(&mut self) {
        self.messages.clear();
        (self.peer_run, self.told) = (self.run, self.run);
    }

    /// The peer is lost, or asked for a keyframe: what it sent belongs to frames this node
    /// will not follow.
    pub fn clear(&mut self) {
        self.messages.clear();
    }

    pub fn display_restarted(&mut self) {
        self.restarts += 1;
    }

    pub fn push(&mut self, m: Message, at: u64) {
        match m {
            Message::StartOver(s) => self.peer_run = self.peer_run.saturating_add(s.restarts),
            m => self.messages.push_back((self.peer_run, m, at)),
        }
    }

    /// This node starts over with the newest display (the peer's messages of older paths are
    /// dropped as [`PeerQueue::pop`] meets them); the returned message tells the peer, before
    /// anything of the new path.
    pub fn start_over(&mut self) -> StartOver {
        self.run = self.restarts;
        let told = StartOver { restarts: self.run - self.told };
        self.told = self.run;
        told
    }

    /// The peer's next message of this node's path; `None` while none has come, or the next
    /// belongs to a path this node has not started over for yet.
    pub fn pop(&mut self) -> Option<(Message, u64)> {
        while let Some((r, ..)) = self.messages.front() {
            if *r > self.run {
                return None;
            }
            let (r, m, at) = self.messages.pop_front()?;
            if r == self.run {
                return Some((m, at));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use osw_wire::{Delta, IdList};

    fn delta(frame: u64) -> Message {
        Message::Delta(Delta { frame, added: IdList::from_ids(&[]), removed: IdList::from_ids(&[]) })
    }

    fn frames(q: &mut PeerQueue) -> Vec<u64> {
        std::iter::from_fn(|| q.pop()).map(|(m, _)| if let Message::Delta(d) = m { d.frame } else { u64::MAX }).collect()
    }

    #[test]
    fn the_old_path_after_this_node_started_over_is_dropped() {
        let mut b = PeerQueue::default();
        b.display_restarted();
        b.start_over();
        // The peer's frames 50 and 51 of the old path were on their way.
        b.push(delta(50), 0);
        b.push(delta(51), 0);
        assert!(frames(&mut b).is_empty());
        b.push(Message::StartOver(StartOver { restarts: 1 }), 0);
        b.push(delta(0), 0);
        assert_eq!(frames(&mut b), [0]);
    }

    #[test]
    fn the_new_path_before_this_node_started_over_waits_for_it() {
        let mut b = PeerQueue::default();
        b.push(delta(7), 0);
        b.push(Message::StartOver(StartOver { restarts: 1 }), 0);
        b.push(delta(0), 0);
        assert_eq!(frames(&mut b), [7]);
        assert!(frames(&mut b).is_empty(), "frame 0 of a path this node has not started");
        b.display_restarted();
        assert_eq!(b.start_over(), StartOver { restarts: 1 });
        assert_eq!(frames(&mut b), [0]);
    }

    #[test]
    fn two_restarts_seen_at_once_by_one_node_and_in_turn_by_the_other() {
        let (mut a, mut b) = (PeerQueue::default(), PeerQueue::default());
        a.display_restarted();
        a.display_restarted();
        let to_b = a.start_over();
        b.display_restarted();
        let to_a = [b.start_over(), {
            b.display_restarted();
            b.start_over()
        }];
        // What each end sends behind its StartOvers: b's frame 1 belongs to the path it
        // started over for first, which a never follows.
        b.push(Message::StartOver(to_b), 0);
        b.push(delta(0), 0);
        a.push(Message::StartOver(to_a[0]), 0);
        a.push(delta(1), 0);
        a.push(Message::StartOver(to_a[1]), 0);
        a.push(delta(2), 0);
        assert_eq!((frames(&mut a), frames(&mut b)), (vec![2], vec![0]));
    }

    #[test]
    fn a_peer_that_says_too_many_restarts_is_never_followed_and_never_overflows() {
        let mut a = PeerQueue::default();
        // Wrapped, u64::MAX + 2 would be this node's first restart.
        a.push(Message::StartOver(StartOver { restarts: u64::MAX }), 0);
        a.push(Message::StartOver(StartOver { restarts: 2 }), 0);
        a.push(delta(0), 0);
        a.display_restarted();
        a.start_over();
        assert!(frames(&mut a).is_empty());
    }

    #[test]
    fn a_new_connection_counts_afresh() {
        let mut a = PeerQueue::default();
        a.display_restarted();
        a.start_over();
        a.push(delta(3), 0);
        // A restarted peer counts from 0: its messages belong to this node's run.
        a.connected();
        assert!(frames(&mut a).is_empty());
        a.push(delta(4), 0);
        a.display_restarted();
        assert_eq!(a.start_over(), StartOver { restarts: 1 });
        a.push(Message::StartOver(StartOver { restarts: 1 }), 0);
        a.push(delta(0), 0);
        assert_eq!(frames(&mut a), [0]);
    }
}
