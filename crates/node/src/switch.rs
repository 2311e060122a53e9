//! The switch node's frame loop (paper 000 alg. 4.2). Frame parity decides the role: node a
//! (index 0) is HC on even frames, node b on odd ones.
//!
//! - HC for frame i: send camera i to RVG first (alg. 4.2 line 6), test the hierarchy against
//!   the depth buffer this node built as OR in frame i-1, stream the visible-set change to the
//!   peer and RVG in batches of b ids, then end of frame with the statistics.
//! - OR for frame i+1 (while the peer is HC for frame i): take camera i+1, draw the front of
//!   V(i-1) updated for it (sec. 4.6) into the depth buffer at once, then each batch of
//!   additions as it arrives, until end of frame; then V(i) = (V(i-1) - removed) ∪ added.
//!
//! Cameras: in path playback every camera carries its frame number and frame k uses the
//! camera numbered k (deterministic runs); RVG sends camera k+2 after it has frame k, so a node
//! never holds more than two.

use crate::link::Event;
use osw_cull::delta::{apply, diff};
use osw_cull::front::update_front;
use osw_gpu::draw::Pass;
use osw_gpu::renderer::{HcTest, Renderer};
use osw_render::mode::hc_pass;
use osw_scene::{Camera, NodeId};
use osw_wire::clock::now_us;
use osw_wire::messages::{CameraPacket, Delta, EndOfFrame, Goodbye, HcWireStats, IdList, Keyframe, LinkStamps, Message, Role};
use std::collections::{BTreeMap, VecDeque};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};
use tokio::sync::mpsc::UnboundedSender;

/// Longest wait for a camera or a peer message before the node gives up.
pub const WAIT: Duration = Duration::from_secs(30);

/// One frame of this node, for its statistics file.
#[derive(Clone, Copy, Debug)]
pub struct NodeFrame {
    pub frame: u64,
    pub hc: bool,
    pub ms: f64,
    pub nodes_drawn: u32,
    pub tests: u32,
    pub ids_sent: u64,
    /// Delta batches and bytes (frames as encoded) this node sent as HC, per link.
    pub batches: u32,
    pub bytes_to_peer: u64,
    pub bytes_to_display: u64,
}

pub struct Switch {
    pub index: u64,
    pub tau: f64,
    pub batch: usize,
    /// Send keyframes (the whole V(i)) instead of deltas.
    pub full: bool,
    pub renderer: Renderer,
    pub events: Receiver<Event>,
    pub to_peer: UnboundedSender<Message>,
    pub to_display: UnboundedSender<Message>,
    /// Cameras by frame, with their arrival times.
    cameras: BTreeMap<u64, (CameraPacket, u64)>,
    peer_queue: VecDeque<(Message, u64)>,
    /// When the peer's end of the previous frame arrived (this node was OR), for the display.
    peer_eof_received_us: u64,
    /// Bytes sent on each link in the current frame: peer, display.
    sent: [u64; 2],
    /// V(i-1), sorted LOD ids.
    visible: Vec<NodeId>,
    done: bool,
}

fn camera(c: &CameraPacket) -> Camera {
    Camera { position: c.position.into(), orientation: glam::DQuat::from_array(c.orientation).normalize(), fovy_deg: c.fovy_deg }
}

impl Switch {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        index: u64,
        tau: f64,
        batch: usize,
        full: bool,
        renderer: Renderer,
        events: Receiver<Event>,
        to_peer: UnboundedSender<Message>,
        to_display: UnboundedSender<Message>,
    ) -> Switch {
        Switch {
            index,
            tau,
            batch,
            full,
            renderer,
            events,
            to_peer,
            to_display,
            cameras: BTreeMap::new(),
            peer_queue: VecDeque::new(),
            peer_eof_received_us: 0,
            sent: [0; 2],
            visible: Vec::new(),
            done: false,
        }
    }

    /// Handles one event; peer messages are queued for [`Switch::peer_message`].
    fn handle(&mut self, e: Event) -> anyhow::Result<()> {
        match e {
            Event::FromDisplay(Message::Camera(c), at) => {
                self.cameras.insert(c.frame, (c, at));
            }
            Event::FromDisplay(Message::Goodbye(_), _) | Event::FromPeer(Message::Goodbye(_), _) => self.done = true,
            Event::FromPeer(m, at) => self.peer_queue.push_back((m, at)),
            Event::FromDisplay(m, _) => tracing::warn!("unexpected message from the display: {m:?}"),
            Event::Connected(role, name) => tracing::info!("{role:?} {name} connected"),
            Event::Closed(role, why) if !self.done => anyhow::bail!("{role:?} connection lost: {why}"),
            Event::Closed(..) => {}
        }
        Ok(())
    }

    fn next_event(&mut self) -> anyhow::Result<()> {
        let e = self.events.recv_timeout(WAIT).map_err(|_| anyhow::anyhow!("nothing heard for {WAIT:?}"))?;
        self.handle(e)
    }

    /// Waits until both the display and the peer are connected.
    pub fn wait_connected(&mut self) -> anyhow::Result<()> {
        let (mut display, mut peer) = (false, false);
        while !(display && peer) {
            match self.events.recv_timeout(WAIT).map_err(|_| anyhow::anyhow!("display and peer not connected within {WAIT:?}"))? {
                Event::Connected(Role::Display, _) => display = true,
                Event::Connected(Role::Node, _) => peer = true,
                e => self.handle(e)?,
            }
        }
        Ok(())
    }

    /// The camera of frame `k` and its arrival time, or `None` when the display said goodbye.
    fn camera(&mut self, k: u64) -> anyhow::Result<Option<(CameraPacket, u64)>> {
        loop {
            if let Some(c) = self.cameras.get(&k).copied() {
                // Older cameras are never needed again.
                self.cameras = self.cameras.split_off(&k);
                return Ok(Some(c));
            }
            if self.done {
                return Ok(None);
            }
            self.next_event()?;
        }
    }

    fn peer_message(&mut self) -> anyhow::Result<Option<(Message, u64)>> {
        loop {
            if let Some(m) = self.peer_queue.pop_front() {
                return Ok(Some(m));
            }
            if self.done {
                return Ok(None);
            }
            self.next_event()?;
        }
    }

    /// Runs frames until the display says goodbye.
    pub fn run(&mut self) -> anyhow::Result<Vec<NodeFrame>> {
        let mut log = Vec::new();
        for i in 0u64.. {
            let f = if i % 2 == self.index { self.hc(i)? } else { self.or(i)? };
            match f {
                Some(f) => log.push(f),
                None => break,
            }
        }
        Ok(log)
    }

    /// Sends `m` to the display and counts its bytes.
    fn send_display(&mut self, m: Message) {
        self.sent[1] += osw_wire::frame_len(&m) as u64;
        let _ = self.to_display.send(m);
    }

    /// Sends `m` to the peer and the display and counts its bytes on both links.
    fn send_both(&mut self, m: Message) {
        self.sent[0] += osw_wire::frame_len(&m) as u64;
        let _ = self.to_peer.send(m.clone());
        self.send_display(m);
    }

    fn hc(&mut self, i: u64) -> anyhow::Result<Option<NodeFrame>> {
        let Some((cam, camera_received_us)) = self.camera(i)? else { return Ok(None) };
        let t = Instant::now();
        self.sent = [0; 2];
        self.send_display(Message::Camera(cam));
        let r = &mut self.renderer;
        r.begin_frame();
        let view = r.view(&camera(&cam));
        if i == 0 {
            // No OR before the first frame: no occluders.
            r.draw(&view, &[], Pass::Depth, true)?;
        }
        let mut pvs = Vec::new();
        let hc = hc_pass(r, &view, self.tau, HcTest::Hybrid, &mut pvs)?;
        let (mut added, mut removed) = (Vec::new(), Vec::new());
        diff(&self.visible, &pvs, &mut added, &mut removed);
        // Batches of at most b ids (sec. 3.5), additions first: OR draws them.
        let mut ids_sent = 0;
        if self.full {
            ids_sent = pvs.len() as u64;
            self.send_both(Message::Keyframe(Keyframe { frame: i, ids: IdList::from_ids(&pvs) }));
            added.clear();
            removed.clear();
        }
        let chunks = added.len().div_ceil(self.batch).max(removed.len().div_ceil(self.batch));
        let batch = self.batch;
        for k in 0..chunks {
            let part = |v: &[u32]| v.iter().skip(k * batch).take(batch).copied().collect::<Vec<_>>();
            let (a, rm) = (part(&added), part(&removed));
            ids_sent += (a.len() + rm.len()) as u64;
            self.send_both(Message::Delta(Delta { frame: i, added: IdList::from_ids(&a), removed: IdList::from_ids(&rm) }));
        }
        let stats =
            HcWireStats { tests: hc.tests, levels: hc.levels, hc_us: t.elapsed().as_micros() as u64, or_us: 0, pvs: pvs.len() as u32 };
        let clock = LinkStamps { sent_us: now_us(), camera_received_us, peer_eof_received_us: self.peer_eof_received_us };
        self.send_both(Message::EndOfFrame(EndOfFrame { frame: i, stats, clock }));
        self.visible = pvs;
        Ok(Some(NodeFrame {
            frame: i,
            hc: true,
            ms: t.elapsed().as_secs_f64() * 1e3,
            nodes_drawn: 0,
            tests: hc.tests,
            ids_sent,
            batches: chunks as u32,
            bytes_to_peer: self.sent[0],
            bytes_to_display: self.sent[1],
        }))
    }

    fn or(&mut self, i: u64) -> anyhow::Result<Option<NodeFrame>> {
        let Some((cam, _)) = self.camera(i + 1)? else { return Ok(None) };
        let t = Instant::now();
        let max_id = self.renderer.scene.header().node_count;
        let r = &mut self.renderer;
        r.begin_frame();
        let view = r.view(&camera(&cam));
        let mut front = Vec::new();
        update_front(r.scene.nodes(), &self.visible, &view, self.tau, &mut front);
        let mut drawn = r.draw(&view, &front, Pass::Depth, true)?.nodes;
        let (mut added, mut removed) = (Vec::new(), Vec::new());
        loop {
            match self.peer_message()? {
                None => return Ok(None),
                Some((Message::Delta(d), _)) if d.frame == i => {
                    let a = d.added.ids(max_id)?;
                    drawn += self.renderer.draw(&view, &a, Pass::Depth, false)?.nodes;
                    added.extend(a);
                    removed.extend(d.removed.ids(max_id)?);
                }
                Some((Message::Keyframe(k), _)) if k.frame == i => {
                    // The whole V(i): draw what V(i-1) lacks, as the deltas would have.
                    let all = k.ids.ids(max_id)?;
                    let (mut a, mut rm) = (Vec::new(), Vec::new());
                    diff(&self.visible, &all, &mut a, &mut rm);
                    drawn += self.renderer.draw(&view, &a, Pass::Depth, false)?.nodes;
                    added.extend(a);
                    removed.extend(rm);
                }
                Some((Message::EndOfFrame(e), at)) if e.frame == i => {
                    self.peer_eof_received_us = at;
                    break;
                }
                Some((m, _)) => anyhow::bail!("frame {i}: unexpected message from the peer: {m:?}"),
            }
        }
        added.sort_unstable();
        removed.sort_unstable();
        self.visible = apply(&self.visible, &removed, &added);
        Ok(Some(NodeFrame {
            frame: i,
            hc: false,
            ms: t.elapsed().as_secs_f64() * 1e3,
            nodes_drawn: drawn,
            tests: 0,
            ids_sent: 0,
            batches: 0,
            bytes_to_peer: 0,
            bytes_to_display: 0,
        }))
    }

    /// Tells everyone this node is leaving.
    pub fn goodbye(&mut self, reason: &str) {
        self.send_both(Message::Goodbye(Goodbye { reason: reason.to_owned() }));
    }
}
