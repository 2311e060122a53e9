//! The switch node's frame loop (paper 000 alg. 4.2). Frame parity decides the role: node a
//! (index 0) is HC on even frames, node b on odd ones.
//!
//! - HC for frame i: send camera i to RVG first (alg. 4.2 line 6), test the hierarchy against
//!   the depth buffer this node built as OR in frame i-1, stream the visible-set change to the
//!   peer and RVG in batches of b ids, then end of frame with the statistics.
//! - OR for frame i+1 (while the peer is HC for frame i): take camera i+1, draw the front of
//!   V(i-1) updated for it (sec. 4.6) into the depth buffer at once, then each batch of
//!   additions (updated for it too) as it arrives, until end of frame; then V(i) =
//!   (V(i-1) - removed) ∪ added.
//!
//! Failover (issue 6): when the peer is gone, this node runs both roles in turn on its own GPU,
//! the single-GPU loop of paper 004 fig. 5: for each frame it draws the front of V(i-1) for
//! camera i as occluders itself, then HC, and sends RVG the whole visible set (a keyframe), so
//! that RVG never depends on what the lost node sent last. A restarted peer asks to rejoin;
//! at the end of its frame this node sends it a keyframe of V(k), runs frame k+1 alone once
//! more (its depth buffer holds camera k's occluders) while the peer draws OR for k+2, and the
//! roles alternate again from there. When only the link between the nodes was cut, both ran
//! alone meanwhile (the one behind catching up with the newest camera); when it is back, node b
//! stops serving and rejoins node a in the same way. Each hello says whether its node has run
//! frames, so that node b does not stop for a peer that was only started anew (that one asks).
//!
//! Cameras: in path playback every camera carries its frame number and frame k uses the
//! camera numbered k (deterministic runs); RVG sends camera k+2 after it has frame k, so a node
//! never holds more than three. Each camera carries the frame's tau (RVG changes it
//! interactively), so the node that is OR and the one that is HC select LODs alike.

use crate::link::{CameraGate, Event, MAX_CAMERAS};
use osw_cull::delta::{Assembly, diff};
use osw_gpu::renderer::{HcTest, Renderer};
use osw_render::mode::{draw_occluders, hc_pass};
use osw_render::packet;
use osw_scene::NodeId;
use osw_wire::clock::now_us;
use osw_wire::messages::{CameraPacket, Delta, EndOfFrame, Goodbye, HcWireStats, IdList, Keyframe, LinkStamps, Message, Rejoin, Role};
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};
use tokio::sync::mpsc::UnboundedSender;

/// Longest wait for a camera or a peer message before the node gives up.
pub const WAIT: Duration = Duration::from_secs(30);

/// One frame of this node, for its statistics file.
#[derive(Clone, Copy, Debug)]
pub struct NodeFrame {
    pub frame: u64,
    pub duty: Duty,
    pub ms: f64,
    pub nodes_drawn: u32,
    pub tests: u32,
    pub ids_sent: u64,
    /// Delta batches and bytes (frames as encoded) this node sent as HC, per link.
    pub batches: u32,
    pub bytes_to_peer: u64,
    pub bytes_to_display: u64,
    /// Resident memory at the end of the frame (a soak shows it flat).
    pub rss_kb: u64,
}

/// What a node did in a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Duty {
    Hc,
    Or,
    /// OR and HC in turn, alone: the first frame, the peer gone, or handing it a keyframe.
    Solo,
}

impl Duty {
    pub fn name(self) -> &'static str {
        match self {
            Duty::Hc => "HC",
            Duty::Or => "OR",
            Duty::Solo => "SOLO",
        }
    }
}

/// A connection the frame loop sends on, and which one it is.
struct Link {
    id: u64,
    out: UnboundedSender<Message>,
}

pub struct Switch {
    pub batch: usize,
    /// Send keyframes (the whole V(i)) instead of deltas.
    pub full: bool,
    /// Adaptive culling's threshold in HC's exact tests (paper 003 eq. 1; 0: conservative).
    pub adaptive: f64,
    /// Longest wait for the peer or the display ([`WAIT`] unless told otherwise).
    pub wait: Duration,
    pub renderer: Renderer,
    events: Receiver<Event>,
    gate: Arc<CameraGate>,
    peer: Option<Link>,
    display: Option<Link>,
    /// Node a (0) or b (1).
    index: u64,
    /// This node is HC on frames with this parity while the peer is up.
    hc_parity: u64,
    /// The camera the depth buffer holds occluders for (set by OR, or by a solo frame).
    depth_for: Option<u64>,
    /// The peer holds the same V(i-1) as this node: it can be OR. False from a peer's loss
    /// until the keyframe that brings it back in step.
    peer_in_step: bool,
    /// The peer asked for a keyframe, and this is the first frame it has not served.
    peer_rejoining: Option<u64>,
    /// This node asked the peer for a keyframe on the current connection.
    rejoin_asked: bool,
    /// The peer said in its hello that it had run frames (see `Hello::serving`).
    peer_serving: bool,
    /// A display connected after the first: a restarted display plays its path from its
    /// first camera, and the nodes start over with it.
    display_restarted: bool,
    displays_seen: u32,
    /// Cameras by frame, with their arrival times.
    cameras: BTreeMap<u64, (CameraPacket, u64)>,
    peer_queue: VecDeque<(Message, u64)>,
    /// When the peer's end of the previous frame arrived (this node was OR), for the display.
    peer_eof_received_us: u64,
    /// Bytes sent on each link in the current frame: peer, display.
    sent: [u64; 2],
    /// V(i-1), sorted LOD ids.
    visible: Vec<NodeId>,
    /// Scratch space for the occluders OR draws.
    occluders: Vec<NodeId>,
    done: bool,
    /// Peer losses and rejoins seen, for the log.
    pub peer_losses: u32,
    pub peer_rejoins: u32,
    /// Cameras dropped here (the oldest, when more than MAX_CAMERAS are held); the gate counts
    /// those dropped on arrival.
    old_cameras_dropped: u64,
}

impl Switch {
    pub fn new(index: u64, batch: usize, full: bool, renderer: Renderer, events: Receiver<Event>, gate: Arc<CameraGate>) -> Switch {
        Switch {
            batch,
            full,
            adaptive: 0.0,
            wait: WAIT,
            renderer,
            events,
            gate,
            peer: None,
            display: None,
            index,
            hc_parity: index,
            depth_for: None,
            peer_in_step: false,
            peer_rejoining: None,
            rejoin_asked: false,
            peer_serving: false,
            display_restarted: false,
            displays_seen: 0,
            cameras: BTreeMap::new(),
            peer_queue: VecDeque::new(),
            peer_eof_received_us: 0,
            sent: [0; 2],
            visible: Vec::new(),
            occluders: Vec::new(),
            done: false,
            peer_losses: 0,
            peer_rejoins: 0,
            old_cameras_dropped: 0,
        }
    }

    /// Cameras from the display that were dropped: too many at once (a flood, or cameras
    /// that piled up while this node was out of the switch).
    pub fn cameras_dropped(&self) -> u64 {
        self.old_cameras_dropped + self.gate.dropped()
    }

    /// Handles one event; peer messages are queued for [`Switch::peer_message`].
    fn handle(&mut self, e: Event) {
        match e {
            Event::FromDisplay(Message::Camera(c), at) => {
                self.gate.taken();
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
            }
            Event::FromDisplay(Message::Goodbye(_), _) => self.done = true,
            // The peer's connection ends next: its loss is handled then (the display's goodbye
            // ends this node, not the peer's, which may have failed).
            Event::FromPeer(Message::Goodbye(g), _) => tracing::info!("the peer leaves: {}", g.reason),
            Event::FromPeer(Message::Rejoin(r), _) => {
                tracing::warn!("the peer rejoins: it gets a keyframe at the end of frame {} or later", r.next.saturating_sub(1));
                // Whatever it held, it holds no longer (it restarted, or it ran alone).
                self.peer_rejoining = Some(r.next);
                self.peer_in_step = false;
                self.peer_queue.clear();
            }
            Event::FromPeer(m, at) => self.peer_queue.push_back((m, at)),
            Event::FromDisplay(m, _) => tracing::warn!("unexpected message from the display: {m:?}"),
            Event::Connected { role, name, serving, id, out } => {
                tracing::info!("{role:?} {name} connected{}", if role == Role::Node && serving { " (serving)" } else { "" });
                let link = Some(Link { id, out });
                match role {
                    Role::Node => {
                        // A new connection replacing one whose end is not seen yet: the peer
                        // is out of step until it rejoins.
                        if self.peer.is_some() {
                            self.peer_in_step = false;
                            self.peer_rejoining = None;
                            self.peer_queue.clear();
                        }
                        self.rejoin_asked = false;
                        self.peer_serving = serving;
                        self.peer = link;
                    }
                    Role::Display => {
                        self.display = link;
                        self.displays_seen += 1;
                        if self.displays_seen > 1 {
                            tracing::warn!("a new display connected: starting over with its path");
                            self.display_restarted = true;
                            self.done = false;
                            self.cameras.clear();
                        }
                    }
                }
            }
            Event::Closed { role, id, why } => {
                let link = match role {
                    Role::Node => &mut self.peer,
                    Role::Display => &mut self.display,
                };
                if link.as_ref().is_some_and(|l| l.id == id) {
                    *link = None;
                    if !self.done {
                        tracing::warn!("{role:?} connection lost ({why}){}", if role == Role::Node { ": running both roles" } else { "" });
                        if role == Role::Node {
                            self.peer_losses += 1;
                            self.peer_in_step = false;
                            self.peer_rejoining = None;
                            self.peer_queue.clear();
                        }
                    }
                }
            }
        }
    }

    /// Handles the next event, waiting at most until `deadline`: the end of the caller's whole
    /// wait, which events that bring nothing it waits for (a camera flood) do not extend.
    fn next_event(&mut self, what: &str, deadline: Instant) -> anyhow::Result<()> {
        let left = deadline.checked_duration_since(Instant::now()).filter(|d| !d.is_zero());
        let e = left
            .and_then(|d| self.events.recv_timeout(d).ok())
            .ok_or_else(|| anyhow::anyhow!("waited {:?} for {what} (--frame-timeout)", self.wait))?;
        self.handle(e);
        Ok(())
    }

    /// Waits until the display and the peer are connected; then, unless the display starts
    /// the path (camera 0), this node restarted into a running cluster and rejoins it.
    /// Returns the first frame to run, or `None` when the display said goodbye first.
    pub fn start(&mut self) -> anyhow::Result<Option<u64>> {
        let deadline = Instant::now() + self.wait;
        while self.display.is_none() || self.peer.is_none() {
            self.next_event("the display and the peer to connect", deadline)?;
        }
        let deadline = Instant::now() + self.wait;
        while self.cameras.is_empty() {
            if self.done {
                return Ok(None);
            }
            self.next_event("the first camera", deadline)?;
        }
        if self.cameras.contains_key(&0) {
            self.peer_in_step = true;
            return Ok(Some(0));
        }
        match self.rejoin(0, false)? {
            None if !self.done => anyhow::bail!("the peer left before this node could rejoin"),
            first => Ok(first),
        }
    }

    /// Asks the peer for its visible set and waits for it (paper 000 has no failover: issue 6);
    /// `next` is the first frame this node has not served. From the frame after the
    /// keyframe's (never before `next`) this node is OR, the peer alone once more. Returns
    /// that frame, or `None` when the wait ends without one: the display said goodbye or
    /// restarted, the peer is gone, or, for a `running` node, the peer asked too (it restarted
    /// and has no visible set: this node hands it one instead) or did not answer in time.
    fn rejoin(&mut self, next: u64, running: bool) -> anyhow::Result<Option<u64>> {
        self.send_peer(Message::Rejoin(Rejoin { next }));
        self.rejoin_asked = true;
        let deadline = Instant::now() + self.wait;
        loop {
            // What the peer sent before the keyframe belongs to frames this node did not follow.
            while let Some((m, _)) = self.peer_queue.pop_front() {
                if let Message::Keyframe(k) = m {
                    self.visible = k.ids.ids(self.renderer.scene.header().node_count)?;
                    self.hc_parity = k.frame % 2;
                    self.peer_in_step = true;
                    self.peer_rejoining = None;
                    self.depth_for = None;
                    self.peer_rejoins += 1;
                    tracing::warn!("rejoined at frame {}", k.frame + 1);
                    return Ok(Some(k.frame + 1));
                }
            }
            if self.done || self.display_restarted || self.peer.is_none() || (running && self.peer_rejoining.is_some()) {
                return Ok(None);
            }
            match self.next_event("a keyframe from the peer", deadline) {
                // A running node goes on alone rather than leave the display with neither.
                Err(e) if running => {
                    tracing::warn!("{e}: going on alone");
                    return Ok(None);
                }
                r => r?,
            }
        }
    }

    /// The camera of frame `k` and its arrival time, or `None` when the display said goodbye.
    /// With `newest_wins` (this node runs alone), when camera k was dropped, the oldest camera
    /// after it: cameras arrive in order, so a newer one held means this node fell behind (the
    /// other node, also alone while the link between them is cut, sets the display's pace),
    /// and it catches up as sec. 4.8.1's receiver would, with the newest camera.
    fn camera(&mut self, k: u64, newest_wins: bool) -> anyhow::Result<Option<(CameraPacket, u64)>> {
        let deadline = Instant::now() + self.wait;
        loop {
            if let Some((&f, &c)) = self.cameras.range(k..).next().filter(|(f, _)| **f == k || newest_wins) {
                // Older cameras are never needed again; camera f is, if this node takes over
                // frame f after all.
                self.cameras = self.cameras.split_off(&f.saturating_sub(1));
                return Ok(Some(c));
            }
            if self.done || self.display_restarted {
                return Ok(None);
            }
            self.next_event(&format!("camera {k}"), deadline)?;
        }
    }

    /// The peer's next message; `None` when the display said goodbye or the peer is gone
    /// (or, with `in_step`, out of step: a new connection from a restarted peer).
    fn peer_message(&mut self, what: &str, in_step: bool) -> anyhow::Result<Option<(Message, u64)>> {
        let deadline = Instant::now() + self.wait;
        loop {
            if let Some(m) = self.peer_queue.pop_front() {
                return Ok(Some(m));
            }
            if self.done || self.display_restarted || self.peer.is_none() || (in_step && !self.peer_in_step) {
                return Ok(None);
            }
            self.next_event(what, deadline)?;
        }
    }

    /// Runs frames from `first` until the display says goodbye.
    pub fn run(&mut self, first: u64) -> anyhow::Result<Vec<NodeFrame>> {
        let (mut log, mut i) = (Vec::new(), first);
        loop {
            while let Ok(e) = self.events.try_recv() {
                self.handle(e);
            }
            if self.display_restarted {
                i = self.start_over()?;
            }
            // The link between the nodes was cut while both ran on, each alone, and is back:
            // node b stops serving and rejoins as a restarted node would, so that the display
            // never mixes frames of two visible sets (node a serves it meanwhile).
            // A peer that was started anew holds nothing to hand over: it asks instead, once
            // the display reaches it, and this node serves on meanwhile.
            if !self.peer_in_step
                && self.index == 1
                && self.peer.is_some()
                && self.peer_serving
                && self.peer_rejoining.is_none()
                && !self.rejoin_asked
            {
                tracing::warn!("the link to the peer is back: rejoining it");
                match self.rejoin(i, true)? {
                    Some(next) => {
                        i = next;
                        continue;
                    }
                    None if self.done => break,
                    None => {}
                }
            }
            let f = if self.peer_in_step && i % 2 != self.hc_parity { self.or(i)? } else { self.hc(i)? };
            match f {
                Some(f) => {
                    i = f.frame + 1;
                    log.push(f);
                }
                None if self.display_restarted => continue,
                None => break,
            }
        }
        Ok(log)
    }

    /// A restarted display: forget the visible set (the display holds none) and run from its
    /// first camera, HC by parity as at start-up. Both nodes do this on their own; the first
    /// frame's HC has no occluders, as at frame 0. Both hold the same empty visible set then:
    /// in step with a connected peer, whatever rejoin was under way.
    fn start_over(&mut self) -> anyhow::Result<u64> {
        self.display_restarted = false;
        self.visible.clear();
        self.peer_queue.clear();
        self.depth_for = None;
        self.hc_parity = self.index;
        self.peer_in_step = self.peer.is_some();
        self.peer_rejoining = None;
        self.rejoin_asked = false;
        let deadline = Instant::now() + self.wait;
        while self.cameras.is_empty() {
            self.next_event("the new display's first camera", deadline)?;
        }
        Ok(*self.cameras.keys().next().expect("a camera"))
    }

    fn send_peer(&mut self, m: Message) {
        if let Some(l) = &self.peer {
            self.sent[0] += osw_wire::frame_len(&m) as u64;
            let _ = l.out.send(m);
        }
    }

    fn send_display(&mut self, m: Message) {
        if let Some(l) = &self.display {
            self.sent[1] += osw_wire::frame_len(&m) as u64;
            let _ = l.out.send(m);
        }
    }

    /// HC for frame i, or both roles when no OR pass prepared camera i's depth buffer (the
    /// first frame, the peer gone, or the frame after handing the peer a keyframe).
    fn hc(&mut self, i: u64) -> anyhow::Result<Option<NodeFrame>> {
        let Some((cam, camera_received_us)) = self.camera(i, !self.peer_in_step)? else { return Ok(None) };
        let i = cam.frame;
        let t = Instant::now();
        self.sent = [0; 2];
        self.send_display(Message::Camera(cam));
        let solo = self.depth_for != Some(i);
        let r = &mut self.renderer;
        r.begin_frame();
        let view = r.view(&packet::camera(&cam));
        let mut drawn = 0;
        if solo {
            // The OR pass of paper 004 fig. 5 on this GPU: the front of V(i-1) for camera i.
            drawn = draw_occluders(r, &view, &self.visible, cam.tau_px, true, &mut self.occluders)?.nodes;
        }
        let mut pvs = Vec::new();
        let hc = hc_pass(r, &view, cam.tau_px, HcTest::Hybrid, self.adaptive, &self.visible, &mut pvs)?;
        let (mut added, mut removed) = (Vec::new(), Vec::new());
        diff(&self.visible, &pvs, &mut added, &mut removed);
        // RVG gets the whole set when it may not hold this node's V(i-1): while running alone.
        let keyframe_to_display = self.full || (solo && i > 0);
        let mut ids_sent = 0;
        if keyframe_to_display {
            ids_sent = pvs.len() as u64;
            self.send_display(keyframe_of(i, &pvs));
        }
        // The peer gets frame i only when it holds V(i-1): else it waits for a keyframe, and
        // anything else would be stale when it comes.
        let to_peer = self.peer_in_step;
        if self.full {
            if to_peer {
                self.send_peer(keyframe_of(i, &pvs));
            }
        } else {
            // Batches of at most b ids (sec. 3.5), additions first: OR draws them.
            let chunks = added.len().div_ceil(self.batch).max(removed.len().div_ceil(self.batch));
            for k in 0..chunks {
                let part = |v: &[u32]| v.iter().skip(k * self.batch).take(self.batch).copied().collect::<Vec<_>>();
                let (a, rm) = (part(&added), part(&removed));
                let delta = Message::Delta(Delta { frame: i, added: IdList::from_ids(&a), removed: IdList::from_ids(&rm) });
                if !keyframe_to_display {
                    ids_sent += (a.len() + rm.len()) as u64;
                    self.send_display(delta.clone());
                }
                if to_peer {
                    self.send_peer(delta);
                }
            }
        }
        let batches = if self.full { 1 } else { added.len().div_ceil(self.batch).max(removed.len().div_ceil(self.batch)) as u32 };
        let stats =
            HcWireStats { tests: hc.tests, levels: hc.levels, hc_us: t.elapsed().as_micros() as u64, or_us: 0, pvs: pvs.len() as u32 };
        let clock = LinkStamps { sent_us: now_us(), camera_received_us, peer_eof_received_us: self.peer_eof_received_us };
        let eof = Message::EndOfFrame(EndOfFrame { frame: i, stats, clock });
        if to_peer {
            self.send_peer(eof.clone());
        }
        self.send_display(eof);
        self.depth_for = Some(i);
        self.visible = pvs;
        // Hand the rejoining peer V(i): it is OR for frame i+1 (with camera i+2), this node
        // alone once more and sending the display a keyframe. Not before the frames the peer
        // served (both alone while the link between them was cut): the display holds those
        // from the peer's visible set, and must not get deltas against them from this one.
        if let Some(next) = self.peer_rejoining
            && self.peer.is_some()
            && i + 1 >= next
        {
            self.send_peer(keyframe_of(i, &self.visible));
            self.peer_rejoining = None;
            self.peer_in_step = true;
            self.hc_parity = (i + 1) % 2;
            self.peer_rejoins += 1;
            tracing::warn!("handed the peer V({i}): the switch resumes at frame {}", i + 2);
        }
        Ok(Some(NodeFrame {
            frame: i,
            duty: if solo { Duty::Solo } else { Duty::Hc },
            ms: t.elapsed().as_secs_f64() * 1e3,
            nodes_drawn: drawn,
            tests: hc.tests,
            ids_sent,
            batches,
            bytes_to_peer: self.sent[0],
            bytes_to_display: self.sent[1],
            rss_kb: osw_render::stats::resident_bytes() >> 10,
        }))
    }

    /// OR for frame i+1 while the peer is HC for frame i. When the peer is lost before its
    /// end of frame, this node runs frame i alone instead.
    fn or(&mut self, i: u64) -> anyhow::Result<Option<NodeFrame>> {
        let Some((cam, _)) = self.camera(i + 1, false)? else { return Ok(None) };
        let t = Instant::now();
        let max_id = self.renderer.scene.header().node_count;
        let r = &mut self.renderer;
        r.begin_frame();
        let view = r.view(&packet::camera(&cam));
        let mut drawn = draw_occluders(r, &view, &self.visible, cam.tau_px, true, &mut self.occluders)?.nodes;
        let mut next = Assembly::default();
        loop {
            match self.peer_message(&format!("frame {i} from the peer"), true)? {
                None if self.done || self.display_restarted => return Ok(None),
                None => {
                    tracing::warn!("frame {i}: the peer is gone; running it alone");
                    self.depth_for = None;
                    return self.hc(i);
                }
                Some((Message::Delta(d), _)) if d.frame == i => {
                    let a = next.delta(d.added.ids(max_id)?, d.removed.ids(max_id)?);
                    drawn += draw_occluders(&mut self.renderer, &view, a, cam.tau_px, false, &mut self.occluders)?.nodes;
                }
                Some((Message::Keyframe(k), _)) if k.frame == i => {
                    // The whole V(i): draw what V(i-1) lacks, as the deltas would have.
                    let a = next.keyframe(&self.visible, &k.ids.ids(max_id)?);
                    drawn += draw_occluders(&mut self.renderer, &view, a, cam.tau_px, false, &mut self.occluders)?.nodes;
                }
                Some((Message::EndOfFrame(e), at)) if e.frame == i => {
                    self.peer_eof_received_us = at;
                    break;
                }
                Some((m, _)) => anyhow::bail!("frame {i}: unexpected message from the peer: {m:?}"),
            }
        }
        self.visible = next.finish(&self.visible);
        self.depth_for = Some(i + 1);
        Ok(Some(NodeFrame {
            frame: i,
            duty: Duty::Or,
            ms: t.elapsed().as_secs_f64() * 1e3,
            nodes_drawn: drawn,
            tests: 0,
            ids_sent: 0,
            batches: 0,
            bytes_to_peer: 0,
            bytes_to_display: 0,
            rss_kb: osw_render::stats::resident_bytes() >> 10,
        }))
    }

    /// Tells everyone this node is leaving.
    pub fn goodbye(&mut self, reason: &str) {
        let m = Message::Goodbye(Goodbye { reason: reason.to_owned() });
        self.send_peer(m.clone());
        self.send_display(m);
    }
}

fn keyframe_of(frame: u64, ids: &[NodeId]) -> Message {
    Message::Keyframe(Keyframe { frame, ids: IdList::from_ids(ids) })
}
