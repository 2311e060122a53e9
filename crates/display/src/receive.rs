//! Receiving one frame: the camera, the visible-set deltas (or a keyframe) and the end of
//! frame from the node that is HC for it, and V(i) = (V(i-1) - removed) ∪ added (occlusion switch
//! sec. 3.4).

use crate::links::{self, Cluster, Note};
use osw_cull::delta::Assembly;
use osw_render::results::DisplayFrame;
use osw_wire::messages::{CameraPacket, EndOfFrame, LinkStamps, Message};
use std::collections::VecDeque;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// How often a wait hands control back (a window keeps answering while the frame comes in).
const SLICE: Duration = Duration::from_millis(15);

/// A node's message as it arrived: node, message, frame bytes, arrival time.
type Arrival = (usize, Message, u64, u64);

pub struct Frames {
    notes: Receiver<Note>,
    pub cluster: Cluster,
    /// V(i), sorted LOD ids.
    pub visible: Vec<u32>,
    /// HC's cluster mask of V(i), when it sent one (osw_wire::messages::ClusterMask).
    pub mask: Option<Vec<u8>>,
    max_id: u32,
    /// The node that sent the previous frame and when it sent its end of frame.
    prev_eof: Option<(usize, u64)>,
    /// Messages not for the frame at hand yet (the next HC may start before this frame is
    /// shown) or from the node that is not its source (kept in case the source is lost).
    held: VecDeque<Arrival>,
    /// Longest wait for a frame.
    wait: Duration,
    /// When the last frame's end arrived, on this display's clock.
    pub eof_at_us: u64,
}

impl Frames {
    /// Waits until both nodes are connected; a frame may then take up to `wait`.
    pub fn connect(notes: Receiver<Note>, max_id: u32, wait: Duration, idle: &mut dyn FnMut()) -> anyhow::Result<Frames> {
        let mut f = Frames {
            notes,
            cluster: Cluster::default(),
            visible: Vec::new(),
            mask: None,
            max_id,
            prev_eof: None,
            held: VecDeque::new(),
            wait,
            eof_at_us: 0,
        };
        let deadline = Instant::now() + wait;
        while f.cluster.nodes.iter().any(Option::is_none) {
            let note = f.next_note(deadline, idle).map_err(|_| anyhow::anyhow!("the nodes did not connect within {wait:?}"))?;
            f.cluster.note(note)?;
        }
        Ok(f)
    }

    /// The next note before `deadline`; `idle` runs every [`SLICE`] while there is none.
    /// The deadline is the caller's whole wait: notes that bring nothing (a node that cannot
    /// be reconnected fails again and again) do not extend it.
    fn next_note(&self, deadline: Instant, idle: &mut dyn FnMut()) -> Result<Note, RecvTimeoutError> {
        loop {
            match self.notes.recv_timeout(SLICE) {
                Err(RecvTimeoutError::Timeout) if Instant::now() < deadline => idle(),
                r if Instant::now() < deadline => return r,
                _ => return Err(RecvTimeoutError::Timeout),
            }
        }
    }

    /// Receives frame `i` and updates [`Frames::visible`] to V(i). Returns the frame's camera
    /// and its row with what arrived filled in; `prev` is frame i-1's row (its HC → OR link
    /// time is known only now).
    pub fn frame(
        &mut self,
        i: u64,
        prev: Option<&mut DisplayFrame>,
        idle: &mut dyn FnMut(),
    ) -> anyhow::Result<(CameraPacket, DisplayFrame)> {
        let mut row = DisplayFrame { frame: i, ..Default::default() };
        // Frame i comes from the node that sends its camera first (the HC node, or the one
        // running alone); if that node is lost before its end of frame, from the other.
        let mut source: Option<(usize, CameraPacket)> = None;
        let mut next = Assembly::default();
        self.mask = None;
        let mut replay: VecDeque<Arrival> = std::mem::take(&mut self.held);
        let max_id = self.max_id;
        let deadline = Instant::now() + self.wait;
        loop {
            let (node, m, bytes, at) = match replay.pop_front() {
                Some(x) => x,
                None => {
                    let note = self
                        .next_note(deadline, idle)
                        .map_err(|_| anyhow::anyhow!("frame {i}: not complete after {:?} (--frame-timeout)", self.wait))?;
                    match self.cluster.note(note)? {
                        Some(x) => x,
                        None => {
                            if let Some((lost, _)) = source.filter(|(n, _)| self.cluster.nodes[*n].is_none()) {
                                tracing::warn!("frame {i}: node {} lost mid-frame; reading the frame from the other", links::NAMES[lost]);
                                source = None;
                                self.forget_partial(&mut next, &mut row);
                                replay = std::mem::take(&mut self.held);
                            }
                            continue;
                        }
                    }
                }
            };
            let from_source = source.is_some_and(|(n, _)| n == node);
            match m {
                Message::Camera(c) if c.frame == i && source.is_none() => {
                    source = Some((node, c));
                    row.bytes += bytes;
                }
                // The source sends frame i again from its start: its link to this display was
                // cut and is back, and it resends its last frames (osw-node's inbox).
                Message::Camera(c) if c.frame == i && from_source => {
                    self.forget_partial(&mut next, &mut row);
                    source = Some((node, c));
                    row.bytes += bytes;
                }
                // Another node's, or another frame's: kept while it may still be needed (an
                // earlier frame's is a node taking over a frame this display already has).
                m if !from_source || m.frame() != Some(i) => {
                    if m.frame().is_some_and(|f| f >= i) {
                        self.held.push_back((node, m, bytes, at));
                    }
                }
                Message::Delta(d) if d.frame == i => {
                    let (ad, rm) = (d.added.ids(max_id)?, d.removed.ids(max_id)?);
                    (row.bytes, row.id_bytes) = (row.bytes + bytes, row.id_bytes + bytes);
                    row.ids_sent += (ad.len() + rm.len()) as u64;
                    next.delta(ad, rm);
                }
                Message::Keyframe(k) if k.frame == i => {
                    // A part of the whole V(i): replaces V(i-1) and what deltas would have built.
                    (row.bytes, row.id_bytes) = (row.bytes + bytes, row.id_bytes + bytes);
                    let part = k.ids.ids(max_id)?;
                    row.ids_sent += part.len() as u64;
                    next.keyframe(&self.visible, k.part, k.parts, part).map_err(|e| anyhow::anyhow!("frame {i}: {e}"))?;
                }
                Message::Clusters(c) if c.frame == i => {
                    (row.bytes, row.mask_bytes) = (row.bytes + bytes, row.mask_bytes + bytes);
                    self.mask = Some(c.bits);
                }
                Message::EndOfFrame(e) if e.frame == i => {
                    row.bytes += bytes;
                    let (hc, cam) = source.expect("from the source");
                    self.end_of_frame(&e, hc, &cam, at, prev, &mut row);
                    break;
                }
                m => anyhow::bail!("frame {i}: unexpected message from node {}: {m:?}", links::NAMES[node]),
            }
        }
        // What the frame's end came before: later frames', or a resent copy of this one.
        self.held.extend(replay);
        let cam = source.expect("a complete frame has a camera").1;
        self.visible = next.finish(&self.visible).map_err(|e| anyhow::anyhow!("frame {i}: {e}"))?;
        row.ids_full = self.visible.len() as u64;
        Ok((cam, row))
    }
}

impl Frames {
    /// Forgets what arrived of a frame that will come again whole.
    fn forget_partial(&mut self, next: &mut Assembly, row: &mut DisplayFrame) {
        *next = Assembly::default();
        (row.bytes, row.id_bytes, row.ids_sent, row.mask_bytes) = (0, 0, 0, 0);
        self.mask = None;
    }

    /// Frame i's end of frame from node `hc`, arrived at `at`: HC's statistics, the links'
    /// latencies and the stages into `row`, and the peer link of frame i-1 into `prev`.
    fn end_of_frame(
        &mut self,
        e: &EndOfFrame,
        hc: usize,
        cam: &CameraPacket,
        at: u64,
        prev: Option<&mut DisplayFrame>,
        row: &mut DisplayFrame,
    ) {
        row.hc_ms = e.stats.hc_us as f64 / 1e3;
        [row.hc_traversal_ms, row.hc_second_look_ms, row.hc_retest_ms] = e.stats.passes_us.map(|us| us as f64 / 1e3);
        (row.tests, row.cull_skipped) = (e.stats.tests, u32::from(e.stats.cull_skipped));
        // Every stamp on the display's clock. The end of frame is stamped when HC queues it,
        // behind the frame's deltas: its link time includes sending them.
        let clock = |n: usize| self.cluster.clocks[n];
        let ms = |later: f64, earlier: f64| (later - earlier) / 1e3;
        row.camera_link_ms = ms(clock(hc).to_display(e.clock.camera_received_us), cam.sampled_us as f64);
        row.eof_link_ms = ms(at as f64, clock(hc).to_display(e.clock.sent_us));
        if let (Some(prev), Some((sender, sent))) = (prev, self.prev_eof.filter(|p| p.0 != hc && e.clock.peer_eof_received_us > 0)) {
            // This node was OR in frame i-1: the peer (HC then) sent its end of frame then, on
            // its clock, and it arrived here.
            prev.peer_link_ms = ms(clock(hc).to_display(e.clock.peer_eof_received_us), clock(sender).to_display(sent));
        }
        self.prev_eof = Some((hc, e.clock.peer_sent_us));
        stages(&e.clock, row);
        self.eof_at_us = at;
        row.hc_node = hc as u32;
        row.degraded = (self.cluster.nodes.iter().any(Option::is_none) || e.stats.degraded) as u32;
    }
}

/// The HC node's stages of a frame from its end of frame's stamps (all on its clock); those
/// a frame has no stamp for stay 0.
fn stages(c: &LinkStamps, row: &mut DisplayFrame) {
    let ms = |later: u64, earlier: u64| if later > 0 && earlier > 0 { later.saturating_sub(earlier) as f64 / 1e3 } else { 0.0 };
    // OR's front ends at the peer's end of frame (or as OR began, when it was already in), or
    // with OR's own pass when the node ran alone.
    let front_end = if c.peer_eof_received_us > 0 { c.peer_eof_received_us.max(c.or_start_us) } else { c.or_end_us };
    row.camera_wait_ms = ms(c.or_start_us, c.camera_received_us);
    row.or_front_ms = ms(front_end, c.or_start_us);
    row.or_tail_ms = ms(c.hc_start_us, front_end);
    row.hc_stage_ms = ms(c.peer_sent_us, c.hc_start_us);
    row.notes_ms = ms(c.sent_us, c.peer_sent_us);
}
