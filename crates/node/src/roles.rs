//! A switch node's roles and failover as a state machine: no renderer, no channels. The
//! frame loop (`switch.rs`) tells it what it hears ([`Roles::on`]) and what it did, and asks
//! it what to do next ([`Roles::step`], [`Roles::duty`]).
//!
//! Paper 000 alg. 4.2: frame parity decides the role, node a (index 0) is HC on even frames
//! and node b on odd ones, while the other is OR. The paper has no failover (docs/switch.md): a node
//! whose peer is gone, or not in step, runs both roles in turn alone (the single-GPU loop of
//! Yoon 2003 fig. 5) and sends RVG keyframes. A restarted peer asks to rejoin; at the end of
//! its frame k this node hands it V(k) and runs frame k+1 alone once more (its depth buffer
//! holds camera k's occluders) while the peer is OR in frame k+1 (camera k+2); the roles
//! alternate from there.
//! When only the link between the nodes was cut, both ran alone; when it is back, node b
//! stops serving and rejoins node a the same way. Each hello says whether its node has run
//! frames (`serving`), so that node b does not stop for a peer that was only started anew.

pub use osw_render::results::Duty;

/// The peer node, as this node knows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Peer {
    /// No connection.
    Gone,
    /// It holds the same V(i-1) as this node: it can be OR while this node is HC.
    InStep,
    /// Connected, holding none of this node's visible sets: a node started anew (it will
    /// ask), or, `serving`, one that ran frames alone while the link between them was cut.
    OutOfStep { serving: bool },
    /// This node asked it for a keyframe on this connection.
    Asked,
    /// It asked this node for a keyframe; `next` is the first frame it has not served.
    Rejoining { next: u64 },
}

/// The display (RVG), as this node knows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Display {
    /// Not connected yet.
    Waiting,
    Playing,
    /// A display connected after the first: a restarted display plays its path from its
    /// first camera, and the nodes start over with it.
    Restarted,
    /// It said goodbye.
    Done,
}

/// What the connections say, as far as roles go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    PeerConnected {
        serving: bool,
    },
    /// The peer's connection ended.
    PeerLost,
    /// The peer asks for a keyframe; `next` is the first frame it has not served.
    PeerRejoins {
        next: u64,
    },
    DisplayConnected,
    DisplayGoodbye,
}

/// What the frame loop must drop after an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Forget {
    /// The peer's queued messages: they belong to frames this node will not follow.
    pub peer_messages: bool,
    /// Held cameras: they belong to a display that is gone.
    pub cameras: bool,
}

/// What the frame loop does next, from frame i.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    Frame(Duty),
    /// Ask the peer for a keyframe and wait for it (node b, after a cut link healed).
    Rejoin,
    /// Forget the visible set and run from the new display's first camera.
    StartOver,
    Stop,
}

/// Frames after a rejoin that are marked degraded. The nodes' HC state then is not what an
/// unbroken run holds: the BVH nodes found visible (CHC's interior nodes, `seen`), the
/// cluster notes and V(i-2) were made alone or not at all. Such state only adds hidden nodes
/// to V(i), the pixels stay prev's, and each HC's retests replace it within a few frames
/// (docs/switch.md, "Failover").
pub const RECOVERY_FRAMES: u64 = 32;

/// While a node runs alone, RVG may hold another node's V(i-1): it gets the whole set.
pub fn keyframe_to_display(i: u64, duty: Duty) -> bool {
    duty == Duty::Solo && i > 0
}

#[derive(Clone, Debug)]
pub struct Roles {
    /// Node a (0) or b (1).
    index: u64,
    /// This node is HC on frames of this parity while the peer is in step.
    hc_parity: u64,
    /// The camera the depth buffer holds occluders for (set by OR, or by a HC frame).
    depth_for: Option<u64>,
    /// The first frame past a rejoin's recovery (see [`RECOVERY_FRAMES`]).
    steady_from: u64,
    pub peer: Peer,
    pub display: Display,
    /// Peer losses and rejoins seen, for the log.
    pub peer_losses: u32,
    pub peer_rejoins: u32,
}

impl Roles {
    pub fn new(index: u64) -> Roles {
        Roles {
            index,
            hc_parity: index,
            depth_for: None,
            steady_from: 0,
            peer: Peer::Gone,
            display: Display::Waiting,
            peer_losses: 0,
            peer_rejoins: 0,
        }
    }

    pub fn on(&mut self, e: Event) -> Forget {
        let mut forget = Forget::default();
        match e {
            Event::PeerConnected { serving } => {
                // A new connection replacing one whose end is not seen yet: that peer's
                // messages are stale.
                forget.peer_messages = self.peer != Peer::Gone;
                self.peer = Peer::OutOfStep { serving };
            }
            Event::PeerLost => {
                if self.display != Display::Done {
                    self.peer_losses += 1;
                }
                forget.peer_messages = true;
                self.peer = Peer::Gone;
            }
            Event::PeerRejoins { next } => {
                // Whatever it held, it holds no longer (it restarted, or it ran alone).
                forget.peer_messages = true;
                self.peer = Peer::Rejoining { next };
            }
            Event::DisplayConnected => {
                if self.display != Display::Waiting {
                    forget.cameras = true;
                    self.display = Display::Restarted;
                } else {
                    self.display = Display::Playing;
                }
            }
            Event::DisplayGoodbye => self.display = Display::Done,
        }
        forget
    }

    /// The first camera arrived: camera 0 starts the path, with the peer when it is there
    /// (both hold the empty set; a peer that asked for a keyframe meanwhile gets one). A later
    /// camera means this node restarted into a running cluster and must rejoin: false.
    pub fn started(&mut self, first_camera: u64) -> bool {
        if first_camera != 0 {
            return false;
        }
        if let Peer::OutOfStep { .. } = self.peer {
            self.peer = Peer::InStep;
        }
        true
    }

    /// A restarted display: both nodes start over on their own, HC by parity and without
    /// occluders as at frame 0, with the same empty visible set, so in step with a connected
    /// peer whatever rejoin was under way (the peer's messages of the old path are told apart
    /// by [`crate::peer_queue::PeerQueue`]).
    pub fn started_over(&mut self) {
        self.display = Display::Playing;
        self.hc_parity = self.index;
        self.depth_for = None;
        self.steady_from = 0;
        if self.peer != Peer::Gone {
            self.peer = Peer::InStep;
        }
    }

    pub fn step(&self, i: u64) -> Step {
        match (self.display, self.peer) {
            (Display::Done, _) => Step::Stop,
            (Display::Restarted, _) => Step::StartOver,
            // Node b stops serving and rejoins as a restarted node would, so that the display
            // never mixes frames of two visible sets (node a serves it meanwhile). A peer
            // started anew holds nothing to hand over: it asks instead.
            (_, Peer::OutOfStep { serving: true }) if self.index == 1 => Step::Rejoin,
            _ => Step::Frame(self.duty(i)),
        }
    }

    /// Alg. 4.2's role for frame i: OR when the peer is in step and HC by parity; else HC,
    /// alone when no OR pass prepared camera i's depth buffer.
    pub fn duty(&self, i: u64) -> Duty {
        if self.peer == Peer::InStep && i % 2 != self.hc_parity {
            Duty::Or
        } else if self.depth_for == Some(i) {
            Duty::Hc
        } else {
            Duty::Solo
        }
    }

    /// HC sends frame i to the peer only when it holds V(i-1): else the peer waits for a
    /// keyframe, and anything else would be stale when it comes.
    pub fn peer_in_step(&self) -> bool {
        self.peer == Peer::InStep
    }

    /// Whether frame i is degraded: HC runs it alone, or the nodes recover from a rejoin.
    pub fn degraded(&self, i: u64) -> bool {
        !self.peer_in_step() || i < self.steady_from
    }

    /// This node asked the peer for a keyframe.
    pub fn asked(&mut self) {
        if let Peer::OutOfStep { .. } = self.peer {
            self.peer = Peer::Asked;
        }
    }

    /// Whether a wait for the keyframe this node asked for goes on. A `running` node stops
    /// when the peer asks too (it restarted and has no visible set: this node hands it one).
    pub fn awaiting_keyframe(&self, running: bool) -> bool {
        self.display == Display::Playing && matches!((self.peer, running), (Peer::Asked, _) | (Peer::Rejoining { .. }, false))
    }

    /// The peer's keyframe of V(k) arrived: this node is OR in frame k+1 (with camera k+2),
    /// and returns k+1.
    pub fn rejoined(&mut self, k: u64) -> u64 {
        self.peer = Peer::InStep;
        self.hc_parity = k % 2;
        self.depth_for = None;
        self.steady_from = k + 1 + RECOVERY_FRAMES;
        self.peer_rejoins += 1;
        k + 1
    }

    /// HC (alone or not) finished frame i, its depth buffer holding camera i's occluders.
    /// Returns whether to hand the rejoining peer V(i) now: it is OR in frame i+1 (with
    /// camera i+2), this node alone once more. Not before the frames the peer served (both
    /// alone while the link was cut): the display holds those from the peer's visible set,
    /// and must not get deltas against them from this node.
    pub fn hc_done(&mut self, i: u64) -> bool {
        self.depth_for = Some(i);
        match self.peer {
            Peer::Rejoining { next } if i + 1 >= next => {
                self.peer = Peer::InStep;
                self.hc_parity = (i + 1) % 2;
                self.steady_from = i + 1 + RECOVERY_FRAMES;
                self.peer_rejoins += 1;
                true
            }
            _ => false,
        }
    }

    /// OR finished in frame i: the depth buffer holds camera i+1's occluders.
    pub fn or_done(&mut self, i: u64) {
        self.depth_for = Some(i + 1);
    }
}

#[cfg(test)]
mod tests {
    //! Two [`Roles`] and a fake network: each test drives a failover sequence of the
    //! process-level tests (`crates/osw/tests/failover.rs`) frame by frame and checks alg.
    //! 4.2's invariant on every frame: exactly one node runs HC for it, and a node is OR only
    //! while its peer is HC for the same frame and both hold the same visible set.
    use super::*;

    /// One node: its roles and its last frame done.
    struct Node {
        roles: Roles,
        /// The frame and the node whose visible set this node's V(i) derives from.
        holds: Option<u64>,
    }

    struct Cluster {
        n: [Node; 2],
        /// Frames served to the display, and by which node's HC.
        served: Vec<(u64, usize)>,
    }

    impl Cluster {
        /// Both nodes connected to each other and the display, at camera 0.
        fn started() -> Cluster {
            let mut n = [0, 1].map(|i| Node { roles: Roles::new(i), holds: None });
            for (x, first) in n.iter_mut().zip([Duty::Solo, Duty::Or]) {
                x.roles.on(Event::DisplayConnected);
                x.roles.on(Event::PeerConnected { serving: false });
                assert!(x.roles.started(0));
                assert_eq!(x.roles.step(0), Step::Frame(first));
            }
            Cluster { n, served: Vec::new() }
        }

        /// Runs frame i on both nodes as the frame loop would, returning their duties.
        fn frame(&mut self, i: u64) -> [Duty; 2] {
            let duty = [0, 1].map(|x| match self.n[x].roles.step(i) {
                Step::Frame(d) => d,
                s => panic!("node {x}, frame {i}: {s:?}"),
            });
            let hc: Vec<usize> = (0..2).filter(|&x| duty[x] != Duty::Or).collect();
            for x in 0..2 {
                if duty[x] == Duty::Or {
                    // OR needs its peer as HC of frame i, in step with it.
                    let p = 1 - x;
                    assert_ne!(duty[p], Duty::Or, "frame {i}: both OR");
                    assert_eq!(self.n[x].holds, self.n[p].holds, "frame {i}: OR on another visible set than HC's");
                    assert!(self.n[p].roles.peer_in_step(), "frame {i}: OR without a peer in step");
                    self.n[x].roles.or_done(i);
                    self.n[x].holds = Some(i);
                }
            }
            for &x in &hc {
                let handover = self.n[x].roles.hc_done(i);
                self.n[x].holds = Some(i);
                if handover {
                    let p = 1 - x;
                    assert!(self.n[p].roles.awaiting_keyframe(false), "frame {i}: keyframe nobody waits for");
                    assert_eq!(self.n[p].roles.rejoined(i), i + 1);
                    self.n[p].holds = Some(i);
                }
            }
            // The display takes frame i from the node whose HC it follows: one, unless both
            // run alone (a cut link), when node a's is shown and node b's dropped.
            self.served.push((i, hc[0]));
            duty
        }

        fn run(&mut self, frames: std::ops::Range<u64>) -> Vec<[Duty; 2]> {
            frames.map(|i| self.frame(i)).collect()
        }
    }

    use Duty::{Hc, Or, Solo};

    #[test]
    fn the_roles_alternate_by_parity_from_frame_zero() {
        let mut c = Cluster::started();
        // Frame 0: both draw no occluders; a runs HC alone, b is OR for frame 1.
        assert_eq!(c.run(0..5), vec![[Solo, Or], [Or, Hc], [Hc, Or], [Or, Hc], [Hc, Or]]);
        assert!(c.served.iter().all(|&(i, x)| x as u64 == i % 2));
    }

    #[test]
    fn a_restarted_node_asks_and_is_handed_a_keyframe() {
        let mut c = Cluster::started();
        c.run(0..4);
        // b dies after frame 3. a was OR for it: its depth holds camera 4's occluders, so
        // frame 4 is a plain HC (deltas to RVG, which holds b's V(3)); then a runs alone.
        c.n[0].roles.on(Event::PeerLost);
        assert_eq!(c.n[0].roles.step(4), Step::Frame(Hc));
        assert!(!c.n[0].roles.hc_done(4));
        assert_eq!(c.n[0].roles.step(5), Step::Frame(Solo));
        assert!(!c.n[0].roles.hc_done(5));
        // b restarts: a new process (no frames served) connects; the display is at frame 7.
        let mut b = Roles::new(1);
        b.on(Event::DisplayConnected);
        b.on(Event::PeerConnected { serving: true });
        c.n[0].roles.on(Event::PeerConnected { serving: false });
        assert!(!b.started(7));
        b.asked();
        assert!(b.awaiting_keyframe(false));
        // a keeps serving alone: a peer started anew is not one to rejoin.
        assert_eq!(c.n[0].roles.step(6), Step::Frame(Solo));
        assert_eq!(c.n[0].roles.on(Event::PeerRejoins { next: 7 }), Forget { peer_messages: true, cameras: false });
        c.n[1].roles = b;
        // Frame 6 is a's alone; b waits. a hands V(6) over at its end (6 + 1 >= 7).
        assert!(c.n[0].roles.hc_done(6));
        assert_eq!(c.n[1].roles.rejoined(6), 7);
        // Frame 7: a alone once more (its depth holds camera 6), b OR for frame 8.
        assert_eq!(c.n[0].roles.duty(7), Solo);
        assert_eq!(c.n[1].roles.duty(7), Or);
        assert!(keyframe_to_display(7, Solo));
        assert_eq!(c.run(7..11), vec![[Solo, Or], [Or, Hc], [Hc, Or], [Or, Hc]]);
        assert_eq!((c.n[0].roles.peer_losses, c.n[0].roles.peer_rejoins, c.n[1].roles.peer_rejoins), (1, 1, 1));
    }

    #[test]
    fn frames_alone_and_those_recovering_from_a_rejoin_are_degraded_until_a_new_path() {
        let mut c = Cluster::started();
        c.run(0..4);
        assert!((0..4).all(|i| !c.n[i as usize % 2].roles.degraded(i)), "a first run, frame 0 included");
        c.n[0].roles.on(Event::PeerLost);
        assert!(c.n[0].roles.degraded(4), "the peer gone");
        c.n[0].roles.on(Event::PeerConnected { serving: false });
        c.n[0].roles.on(Event::PeerRejoins { next: 6 });
        c.n[1].roles = Roles::new(1);
        c.n[1].roles.on(Event::DisplayConnected);
        c.n[1].roles.on(Event::PeerConnected { serving: true });
        c.n[1].roles.asked();
        c.run(4..6);
        let steady = 6 + RECOVERY_FRAMES;
        c.run(6..steady + 2);
        for x in &c.n {
            assert!((6..steady).all(|i| x.roles.degraded(i)) && !x.roles.degraded(steady));
        }
        // A restarted display: both nodes start over, frame 0 as in a first run.
        for x in &mut c.n {
            x.roles.on(Event::DisplayConnected);
            x.roles.started_over();
            assert!(!x.roles.degraded(0));
        }
    }

    #[test]
    fn a_keyframe_is_not_handed_before_the_frames_the_peer_served() {
        let mut a = Roles::new(0);
        a.on(Event::DisplayConnected);
        a.on(Event::PeerConnected { serving: false });
        a.started(0);
        a.on(Event::PeerRejoins { next: 10 });
        assert!(!a.hc_done(7));
        assert!(!a.hc_done(8));
        assert!(a.hc_done(9));
        assert!(a.peer_in_step());
        assert_eq!(a.duty(10), Solo);
        assert_eq!(a.duty(11), Or);
    }

    #[test]
    fn a_cut_link_runs_both_alone_then_b_rejoins_a() {
        let mut c = Cluster::started();
        c.run(0..4);
        for x in &mut c.n {
            assert!(x.roles.on(Event::PeerLost).peer_messages);
        }
        // Both serve the display alone (a's frame 4 on the occluders it drew as OR).
        assert_eq!(c.run(4..7), vec![[Hc, Solo], [Solo, Solo], [Solo, Solo]]);
        assert!(keyframe_to_display(5, Solo) && !keyframe_to_display(0, Solo) && !keyframe_to_display(5, Hc));
        // The link is back: both have served frames.
        for x in &mut c.n {
            x.roles.on(Event::PeerConnected { serving: true });
        }
        // a serves on; b stops and asks.
        assert_eq!(c.n[0].roles.step(7), Step::Frame(Solo));
        assert_eq!(c.n[1].roles.step(7), Step::Rejoin);
        c.n[1].roles.asked();
        assert_eq!(c.n[1].roles.step(7), Step::Frame(Solo), "b asks once per connection");
        c.n[0].roles.on(Event::PeerRejoins { next: 7 });
        assert!(c.n[0].roles.hc_done(7));
        assert!(c.n[1].roles.awaiting_keyframe(true));
        assert_eq!(c.n[1].roles.rejoined(7), 8);
        assert_eq!(c.run(8..12), vec![[Solo, Or], [Or, Hc], [Hc, Or], [Or, Hc]]);
    }

    #[test]
    fn a_running_node_that_asks_stops_waiting_when_the_peer_asks_too() {
        // The link healed but a restarted just now: it asks as a restarted node does, and b
        // (which asked first) hands it a keyframe instead of waiting.
        let mut b = Roles::new(1);
        b.on(Event::DisplayConnected);
        b.on(Event::PeerConnected { serving: true });
        b.asked();
        assert!(b.awaiting_keyframe(true));
        b.on(Event::PeerRejoins { next: 20 });
        assert!(!b.awaiting_keyframe(true));
        assert!(b.awaiting_keyframe(false), "a starting node has nothing to hand over: it waits on");
        assert!(b.hc_done(19));
    }

    #[test]
    fn waiting_for_a_keyframe_ends_with_the_peer_or_the_display() {
        let asked = || {
            let mut r = Roles::new(1);
            r.on(Event::DisplayConnected);
            r.on(Event::PeerConnected { serving: true });
            r.asked();
            r
        };
        let mut r = asked();
        r.on(Event::PeerLost);
        assert!(!r.awaiting_keyframe(true));
        let mut r = asked();
        r.on(Event::DisplayGoodbye);
        assert!(!r.awaiting_keyframe(false));
        assert_eq!(r.step(3), Step::Stop);
        let mut r = asked();
        // A new connection (the peer restarted meanwhile) will not answer the old request.
        r.on(Event::PeerConnected { serving: false });
        assert!(!r.awaiting_keyframe(false));
    }

    #[test]
    fn a_restarted_display_starts_both_nodes_over_in_step() {
        let mut c = Cluster::started();
        c.run(0..6);
        // A rejoin was under way on a when the display restarted.
        c.n[0].roles.on(Event::PeerRejoins { next: 9 });
        for x in &mut c.n {
            assert_eq!(x.roles.on(Event::DisplayConnected), Forget { peer_messages: false, cameras: true });
            assert_eq!(x.roles.step(6), Step::StartOver);
            x.roles.started_over();
            x.holds = None;
        }
        // From the new display's first camera: as from frame 0.
        assert_eq!(c.run(0..3), vec![[Solo, Or], [Or, Hc], [Hc, Or]]);
    }

    #[test]
    fn a_display_restart_with_the_peer_gone_runs_alone() {
        let mut a = Roles::new(0);
        a.on(Event::DisplayConnected);
        a.on(Event::PeerConnected { serving: false });
        a.started(0);
        a.on(Event::PeerLost);
        a.on(Event::DisplayConnected);
        a.started_over();
        assert_eq!(a.peer, Peer::Gone);
        assert_eq!((a.step(0), a.step(1)), (Step::Frame(Solo), Step::Frame(Solo)));
    }

    #[test]
    fn camera_zero_starts_alone_without_a_peer_and_keeps_a_rejoin_asked_before_it() {
        let mut a = Roles::new(0);
        a.on(Event::DisplayConnected);
        assert!(a.started(0));
        assert_eq!(a.step(0), Step::Frame(Solo));
        let mut a = Roles::new(0);
        a.on(Event::DisplayConnected);
        a.on(Event::PeerConnected { serving: false });
        a.on(Event::PeerRejoins { next: 0 });
        assert!(a.started(0));
        assert!(a.hc_done(0), "the peer that asked gets V(0)");
    }

    #[test]
    fn a_loss_after_goodbye_is_not_counted() {
        let mut a = Roles::new(0);
        a.on(Event::DisplayConnected);
        a.on(Event::PeerConnected { serving: false });
        a.on(Event::DisplayGoodbye);
        a.on(Event::PeerLost);
        assert_eq!((a.peer_losses, a.step(9)), (0, Step::Stop));
    }

    #[test]
    fn a_peer_lost_during_or_leaves_the_frame_to_this_node_alone() {
        let mut c = Cluster::started();
        c.run(0..3);
        // a is OR for frame 3 (b is HC) when its connection to b ends.
        assert_eq!(c.n[1].roles.duty(3), Hc);
        assert_eq!(c.n[0].roles.duty(3), Or);
        c.n[0].roles.on(Event::PeerLost);
        assert_eq!(c.n[0].roles.duty(3), Solo);
        assert!(!c.n[0].roles.peer_in_step());
    }
}
