//! The peer's messages in arrival order, each with the display session it belongs to.
//!
//! A restarted display (RVG) connects to both nodes, and each starts over when its own
//! connection says so: the peer may still send frames of the old path after this node started
//! over, or frames of the new path before. Each display says its session in its hello (when it
//! started: a later display has a larger one, a reconnecting display keeps its own), and each
//! node tells its peer the session it follows with a `StartOver` ahead of its first message of
//! that path, and first on every new connection; TCP keeps the order, so every message is known
//! to belong to a session, and is used in that session only.

use osw_wire::messages::{Message, StartOver};
use std::collections::VecDeque;

#[derive(Default)]
pub struct PeerQueue {
    /// (session, message, arrival time).
    messages: VecDeque<(u64, Message, u64)>,
    /// The display session whose path this node follows (0: none yet).
    session: u64,
    /// The session the peer's messages belong to now, as its last `StartOver` said.
    peer_session: u64,
}

impl PeerQueue {
    /// A new connection to the peer: what the old one brought is stale, and the peer says its
    /// session first.
    pub fn connected(&mut self) {
        self.messages.clear();
        self.peer_session = 0;
    }

    /// The peer is lost, or asked for a keyframe: what it sent belongs to frames this node
    /// will not follow.
    pub fn clear(&mut self) {
        self.messages.clear();
    }

    pub fn push(&mut self, m: Message, at: u64) {
        match m {
            Message::StartOver(s) => self.peer_session = s.session,
            m => self.messages.push_back((self.peer_session, m, at)),
        }
    }

    /// The session this node follows (0: none yet).
    pub fn session(&self) -> u64 {
        self.session
    }

    /// This node follows display `session` from here (the peer's messages of older sessions
    /// are dropped as [`PeerQueue::pop`] meets them); the returned message tells the peer,
    /// before anything of the new path.
    pub fn follow(&mut self, session: u64) -> StartOver {
        self.session = session;
        StartOver { session }
    }

    /// The peer's next message of this node's path; `None` while none has come, or the next
    /// belongs to a later display that this node does not follow yet.
    pub fn pop(&mut self) -> Option<(Message, u64)> {
        while let Some((s, ..)) = self.messages.front() {
            if *s > self.session {
                return None;
            }
            let (s, m, at) = self.messages.pop_front()?;
            if s == self.session {
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

    fn start_over(session: u64) -> Message {
        Message::StartOver(StartOver { session })
    }

    #[test]
    fn the_old_path_after_this_node_started_over_is_dropped() {
        let mut b = PeerQueue::default();
        b.push(start_over(10), 0);
        b.follow(20);
        // The peer's frames 50 and 51 of the old path were on their way.
        b.push(delta(50), 0);
        b.push(delta(51), 0);
        assert!(frames(&mut b).is_empty());
        b.push(start_over(20), 0);
        b.push(delta(0), 0);
        assert_eq!(frames(&mut b), [0]);
    }

    #[test]
    fn the_new_path_before_this_node_started_over_waits_for_it() {
        let mut b = PeerQueue::default();
        b.follow(10);
        b.push(start_over(10), 0);
        b.push(delta(7), 0);
        b.push(start_over(20), 0);
        b.push(delta(0), 0);
        assert_eq!(frames(&mut b), [7]);
        assert!(frames(&mut b).is_empty(), "frame 0 of a path this node has not started");
        assert_eq!(b.follow(20), StartOver { session: 20 });
        assert_eq!(frames(&mut b), [0]);
    }

    #[test]
    fn a_node_restarted_before_a_new_display_follows_it_as_its_peer_does() {
        // Node b follows the display of session 10 and meets a restarted node a, which follows
        // none; then the display of session 20 connects to both: a's first, b's second.
        let (mut a, mut b) = (PeerQueue::default(), PeerQueue::default());
        b.follow(10);
        a.connected();
        b.connected();
        a.push(start_over(b.session()), 0);
        a.push(delta(30), 0);
        let (to_b, to_a) = (a.follow(20), b.follow(20));
        a.push(Message::StartOver(to_a), 0);
        a.push(delta(0), 0);
        b.push(Message::StartOver(to_b), 0);
        b.push(delta(1), 0);
        assert_eq!((frames(&mut a), frames(&mut b)), (vec![0], vec![1]));
    }

    #[test]
    fn two_displays_seen_in_turn_by_one_node_and_at_once_by_the_other() {
        let (mut a, mut b) = (PeerQueue::default(), PeerQueue::default());
        let to_b = a.follow(30);
        let to_a = [b.follow(20), b.follow(30)];
        // What each end sends behind its StartOvers: b's frame 1 belongs to the display it
        // followed first, which a never follows.
        b.push(Message::StartOver(to_b), 0);
        b.push(delta(0), 0);
        a.push(Message::StartOver(to_a[0]), 0);
        a.push(delta(1), 0);
        a.push(Message::StartOver(to_a[1]), 0);
        a.push(delta(2), 0);
        assert_eq!((frames(&mut a), frames(&mut b)), (vec![2], vec![0]));
    }

    #[test]
    fn a_new_connection_waits_for_the_peers_session() {
        let mut a = PeerQueue::default();
        a.follow(10);
        a.push(start_over(10), 0);
        a.push(delta(3), 0);
        // A restarted peer follows no display yet: its messages until it says one are dropped.
        a.connected();
        assert!(frames(&mut a).is_empty());
        a.push(delta(4), 0);
        a.push(start_over(10), 0);
        a.push(delta(5), 0);
        assert_eq!(frames(&mut a), [5]);
    }
}
