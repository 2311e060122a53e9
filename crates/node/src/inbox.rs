//! What the frame loop hears and sends: the connections' events, the display's cameras, the
//! peer's messages, and the [`Roles`] they change. Waits are bounded (`--frame-timeout`).

use crate::link::{CameraGate, Event, MAX_CAMERAS};
use crate::peer_queue::PeerQueue;
use crate::roles::{self, Display, Forget, Roles};
use osw_cull::delta::Assembly;
use osw_scene::NodeId;
use osw_wire::messages::{CameraPacket, Message, Role, StartOver};
use osw_wire::{Frame, WireError};
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};
use tokio::sync::mpsc::UnboundedSender;

/// A connection the frame loop sends on, and which one it is.
struct Link {
    id: u64,
    out: UnboundedSender<Frame>,
}

pub struct Inbox {
    pub roles: Roles,
    /// Longest wait for the peer or the display.
    pub wait: Duration,
    /// Bytes sent on each link in the current frame: peer, display.
    pub sent: [u64; 2],
    events: Receiver<Event>,
    gate: Arc<CameraGate>,
    peer: Option<Link>,
    display: Option<Link>,
    /// Cameras by frame, with their arrival times.
    cameras: BTreeMap<u64, (CameraPacket, u64)>,
    peer_queue: PeerQueue,
    /// The session of the display last connected ([`osw_wire::Hello::session`]).
    display_session: u64,
    /// The parts of a rejoin's keyframe so far, and its frame.
    rejoin: Option<(u64, Assembly)>,
    /// Cameras dropped here (the oldest, when more than MAX_CAMERAS are held); the gate
    /// counts those dropped on arrival.
    old_cameras_dropped: u64,
    /// What this node sent the display of its last [`RESENT_FRAMES`] frames, by frame: sent
    /// again when the display's link is cut and back (the display drops what it has).
    to_display: VecDeque<(u64, Frame)>,
    /// The display reconnected: [`Inbox::to_display`] goes out with its first camera (the
    /// display probes the clock first, and takes nothing else until then).
    resend: bool,
}

/// Frames resent to a display that reconnects: RVG sends camera k+2 once it has frame k, so a
/// node holds at most frames k..k+1 that RVG lacks; one more for a frame under way.
const RESENT_FRAMES: u64 = 3;

impl Inbox {
    pub fn new(index: u64, events: Receiver<Event>, gate: Arc<CameraGate>) -> Inbox {
        Inbox {
            roles: Roles::new(index),
            wait: osw_wire::limits::FRAME_WAIT,
            sent: [0; 2],
            events,
            gate,
            peer: None,
            display: None,
            cameras: BTreeMap::new(),
            peer_queue: PeerQueue::default(),
            display_session: 0,
            rejoin: None,
            old_cameras_dropped: 0,
            to_display: VecDeque::new(),
            resend: false,
        }
    }

    /// Cameras from the display that were dropped: too many at once (a flood, or cameras
    /// that piled up while this node was out of the switch).
    pub fn cameras_dropped(&self) -> u64 {
        self.old_cameras_dropped + self.gate.dropped()
    }

    /// Handles what has arrived, without waiting.
    pub fn drain(&mut self) {
        while let Ok(e) = self.events.try_recv() {
            self.handle(e);
        }
    }

    fn handle(&mut self, e: Event) {
        let forget = match e {
            // What an earlier display connection still brings after its replacement connected
            // (a relay or a slow link delivers it late): a killed display's last cameras would
            // start the new display's path in the middle of the old one.
            Event::FromDisplay(m, _, link) if self.display.as_ref().is_none_or(|l| l.id != link) => {
                if matches!(m, Message::Camera(_)) {
                    self.gate.taken();
                }
                Forget::default()
            }
            Event::FromDisplay(Message::Camera(c), at, _) => {
                self.gate.taken();
                if std::mem::take(&mut self.resend) {
                    self.resend_to_display();
                }
                self.cameras.insert(c.frame, (c, at));
                // The newest cameras are kept (sec. 4.8.1: the newest camera wins). Many pile
                // up only while this node is not taking part: a restarted node waiting for its
                // keyframe, whose frame is then the display's newest but two.
                if self.cameras.len() > MAX_CAMERAS {
                    self.cameras.pop_first();
                    self.old_cameras_dropped += 1;
                    if self.old_cameras_dropped == 1 {
                        tracing::warn!("more than {MAX_CAMERAS} cameras held: dropping the oldest");
                    }
                }
                Forget::default()
            }
            Event::FromDisplay(Message::Goodbye(_), ..) => self.roles.on(roles::Event::DisplayGoodbye),
            // The peer's connection ends next: its loss is handled then (the display's goodbye
            // ends this node, not the peer's, which may have failed).
            Event::FromPeer(Message::Goodbye(g), _) => {
                tracing::info!("the peer leaves: {}", g.reason);
                Forget::default()
            }
            Event::FromPeer(Message::Rejoin(r), _) => {
                tracing::warn!("the peer rejoins: it gets a keyframe at the end of frame {} or later", r.next.saturating_sub(1));
                self.roles.on(roles::Event::PeerRejoins { next: r.next })
            }
            Event::FromPeer(m, at) => {
                self.peer_queue.push(m, at);
                Forget::default()
            }
            Event::FromDisplay(m, ..) => {
                tracing::warn!("unexpected message from the display: {m:?}");
                Forget::default()
            }
            Event::Connected { role, name, serving, session, id, out } => {
                tracing::info!("{role:?} {name} connected{}", if role == Role::Node && serving { " (serving)" } else { "" });
                let link = Link { id, out };
                match role {
                    Role::Node => {
                        self.peer = Some(link);
                        self.peer_queue.connected();
                        // The peer learns first which display's path this node follows.
                        if self.peer_queue.session() != 0 {
                            let _ = self.send_peer(&Message::StartOver(StartOver { session: self.peer_queue.session() }));
                        }
                        self.roles.on(roles::Event::PeerConnected { serving })
                    }
                    // The same display, its link cut and back: it goes on with its path, and
                    // gets again what it may have missed.
                    Role::Display if session == self.display_session && self.roles.display == Display::Playing => {
                        self.display = Some(link);
                        self.resend = true;
                        Forget::default()
                    }
                    Role::Display => {
                        self.display = Some(link);
                        self.display_session = session;
                        self.to_display.clear();
                        let f = self.roles.on(roles::Event::DisplayConnected);
                        if self.roles.display == Display::Restarted {
                            tracing::warn!("a new display connected: starting over with its path");
                        } else {
                            // The first display: its path is this node's from here.
                            let told = self.peer_queue.follow(session);
                            let _ = self.send_peer(&Message::StartOver(told));
                        }
                        f
                    }
                }
            }
            Event::Closed { role, id, why } => {
                let link = match role {
                    Role::Node => &mut self.peer,
                    Role::Display => &mut self.display,
                };
                if link.as_ref().is_none_or(|l| l.id != id) {
                    return;
                }
                *link = None;
                if self.roles.display != Display::Done {
                    tracing::warn!("{role:?} connection lost ({why}){}", if role == Role::Node { ": running both roles" } else { "" });
                }
                match role {
                    Role::Node => self.roles.on(roles::Event::PeerLost),
                    Role::Display => Forget::default(),
                }
            }
        };
        self.forget(forget);
    }

    /// Sends the display again what it may have missed while its link was cut.
    fn resend_to_display(&self) {
        let frames = self.to_display.front().zip(self.to_display.back()).map(|(a, b)| a.0..=b.0);
        tracing::warn!("the display reconnected: sending it frames {frames:?} again");
        if let Some(l) = &self.display {
            self.to_display.iter().for_each(|(_, f)| drop(l.out.send(f.clone())));
        }
    }

    /// A restarted display: both roles start over, and the peer is told before anything this
    /// node sends of the new path.
    pub fn start_over(&mut self) -> Result<(), WireError> {
        self.roles.started_over();
        let told = self.peer_queue.follow(self.display_session);
        self.send_peer(&Message::StartOver(told))
    }

    pub fn forget(&mut self, f: Forget) {
        if f.peer_messages {
            self.peer_queue.clear();
        }
        if f.cameras {
            self.cameras.clear();
        }
    }

    /// Handles the next event, waiting at most until `deadline`: the end of the caller's whole
    /// wait, which events that bring nothing it waits for (a camera flood) do not extend.
    pub fn next_event(&mut self, what: &str, deadline: Instant) -> anyhow::Result<()> {
        let left = deadline.checked_duration_since(Instant::now()).filter(|d| !d.is_zero());
        let e = left
            .and_then(|d| self.events.recv_timeout(d).ok())
            .ok_or_else(|| anyhow::anyhow!("waited {:?} for {what} (--frame-timeout)", self.wait))?;
        self.handle(e);
        Ok(())
    }

    /// Waits until the display and the peer are connected.
    pub fn connected(&mut self) -> anyhow::Result<()> {
        let deadline = Instant::now() + self.wait;
        while self.display.is_none() || self.peer.is_none() {
            self.next_event("the display and the peer to connect", deadline)?;
        }
        Ok(())
    }

    /// The frame of the display's first camera, or `None` when it said goodbye first.
    pub fn first_camera(&mut self, what: &str) -> anyhow::Result<Option<u64>> {
        let deadline = Instant::now() + self.wait;
        loop {
            if let Some(&k) = self.cameras.keys().next() {
                return Ok(Some(k));
            }
            if self.roles.display == Display::Done {
                return Ok(None);
            }
            self.next_event(what, deadline)?;
        }
    }

    /// The camera of frame `k` and its arrival time, or `None` when the display said goodbye
    /// or restarted. With `newest_wins` (this node runs alone), when camera k was dropped, the
    /// oldest camera after it: cameras arrive in order, so a newer one held means this node
    /// fell behind (the other node, also alone while the link between them is cut, sets the
    /// display's pace), and it catches up as sec. 4.8.1's receiver would, with the newest.
    pub fn camera(&mut self, k: u64, newest_wins: bool) -> anyhow::Result<Option<(CameraPacket, u64)>> {
        let deadline = Instant::now() + self.wait;
        loop {
            if let Some((&f, &c)) = self.cameras.range(k..).next().filter(|(f, _)| **f == k || newest_wins) {
                // Older cameras are never needed again; camera f is, if this node takes over
                // frame f after all.
                self.cameras = self.cameras.split_off(&f.saturating_sub(1));
                return Ok(Some(c));
            }
            if self.roles.display != Display::Playing {
                return Ok(None);
            }
            self.next_event(&format!("camera {k}"), deadline)?;
        }
    }

    /// The in-step peer's next message (`i` names the frame waited for in a timeout's message);
    /// `None` when the display said goodbye or restarted, or the peer is gone or out of step
    /// (a new connection from a restarted peer).
    pub fn peer_message(&mut self, i: u64) -> anyhow::Result<Option<(Message, u64)>> {
        let deadline = Instant::now() + self.wait;
        loop {
            if let Some(m) = self.peer_queue.pop() {
                return Ok(Some(m));
            }
            if self.roles.display != Display::Playing || !self.roles.peer_in_step() {
                return Ok(None);
            }
            self.next_event(&format!("frame {i} from the peer"), deadline)?;
        }
    }

    /// V(k) and k, once every part of the keyframe the peer sent in answer to a rejoin has
    /// come; what it sent before belongs to frames this node did not follow.
    pub fn keyframe(&mut self, max_id: u32) -> Result<Option<(u64, Vec<NodeId>)>, WireError> {
        while let Some((m, _)) = self.peer_queue.pop() {
            if let Message::Keyframe(k) = m {
                let ids = k.ids.ids(max_id)?;
                // A part of another frame's keyframe starts that one afresh.
                let (frame, mut parts) = match self.rejoin.take() {
                    Some((f, a)) if f == k.frame => (f, a),
                    _ => (k.frame, Assembly::default()),
                };
                parts.keyframe(&[], k.part, k.parts, ids).map_err(|e| WireError::BadIds(e.to_string()))?;
                if k.part + 1 == k.parts {
                    return Ok(Some((frame, parts.finish(&[]).map_err(|e| WireError::BadIds(e.to_string()))?)));
                }
                self.rejoin = Some((frame, parts));
            }
        }
        Ok(None)
    }

    /// Sends `m`, encoded once, to the peer and the display as asked, where connected, and
    /// counts its bytes on each link. A message too large for a frame is an error.
    pub fn send(&mut self, m: &Message, to_peer: bool, to_display: bool) -> Result<(), WireError> {
        let f = Frame::new(m)?;
        for (k, (on, link)) in [(to_peer, &self.peer), (to_display, &self.display)].into_iter().enumerate() {
            if let (true, Some(l)) = (on, link) {
                self.sent[k] += f.len() as u64;
                let _ = l.out.send(f.clone());
            }
        }
        if let (true, Some(frame)) = (to_display, m.frame()) {
            self.to_display.push_back((frame, f));
            while self.to_display.front().is_some_and(|(k, _)| k + RESENT_FRAMES <= frame) {
                self.to_display.pop_front();
            }
        }
        Ok(())
    }

    pub fn send_peer(&mut self, m: &Message) -> Result<(), WireError> {
        self.send(m, true, false)
    }

    pub fn send_display(&mut self, m: &Message) -> Result<(), WireError> {
        self.send(m, false, true)
    }
}
