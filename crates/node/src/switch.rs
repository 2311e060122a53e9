//! The switch node's frame loop (occlusion switch alg. 4.2); who does what in a frame, and failover,
//! are [`Roles`](crate::roles)'s.
//!
//! - HC for frame i: send camera i to RVG first (alg. 4.2 line 6), test the hierarchy against
//!   the depth buffer this node built as OR in frame i-1, stream the visible-set change to the
//!   peer and RVG in batches of at most b added and b removed ids (sec. 3.5), then end of
//!   frame with the statistics.
//! - OR in frame i (while the peer is HC for frame i): take camera i+1, draw the front of
//!   V(i-1) updated for it (sec. 4.6) into the depth buffer at once, then each batch of
//!   additions (updated for it too) as it arrives, until end of frame; then V(i) =
//!   (V(i-1) - removed) ∪ added (sec. 3.4).
//! - Solo (no peer in step): the OR pass of Yoon 2003 fig. 5 on this GPU, then HC.
//!
//! Cameras: in path playback every camera carries its frame number and frame k uses the
//! camera numbered k (deterministic runs); RVG sends camera k+2 after it has frame k, so a node
//! never holds more than three. Each camera carries the frame's tau (RVG changes it
//! interactively), so the node that is OR and the one that is HC select LODs alike.

use crate::inbox::Inbox;
use crate::roles::{Display, Duty, Peer, Step, keyframe_to_display};
use osw_cull::delta::{Assembly, batches, diff};
use osw_cull::frustum_cull;
use osw_cull::payoff::Payoff;
use osw_gpu::draw::Load;
use osw_gpu::renderer::{DrawStats, Renderer};
use osw_render::packet;
use osw_render::pass::{self, HcOptions, HcPass, Occluders};
use osw_render::results::NodeFrame;
use osw_scene::{NodeId, SceneFile};
use osw_wire::clock::now_us;
use osw_wire::messages::{ClusterMask, Delta, EndOfFrame, Goodbye, HcWireStats, IdList, Keyframe, LinkStamps, Message, Rejoin};
use std::time::Instant;

pub struct Switch {
    pub batch: usize,
    /// Send keyframes (the whole V(i)) instead of deltas.
    pub full: bool,
    /// Largest coding of a keyframe part's ids (osw_wire::limits::KEYFRAME_PART_BYTES).
    pub keyframe_part_bytes: usize,
    /// Adaptive culling's threshold in HC's exact tests (Bartz 1999 eq. 1; 0: conservative).
    pub adaptive: f64,
    /// Cost-adaptive culling of the frames this node culls (osw_cull::payoff); None culls
    /// every frame.
    pub payoff: Option<Payoff>,
    /// Whether HC of the next frame culls, decided as OR prepares its depth buffer.
    next: Option<bool>,
    scene: SceneFile,
    pub renderer: Renderer,
    pub io: Inbox,
    /// V(i-1), sorted LOD ids.
    visible: Vec<NodeId>,
    /// Scratch space for the occluders OR draws.
    occluders: Vec<NodeId>,
    /// The BVH nodes this node's last HC found visible (osw_cull::hardware_cull_seen).
    seen: Vec<NodeId>,
    /// When the peer's end of the previous frame arrived (this node was OR), for the display.
    peer_eof_received_us: u64,
    /// When this node's last OR began and ended: the next HC's camera's stages.
    or_us: [u64; 2],
}

impl Switch {
    /// A switch node on `renderer`, made for `scene`.
    pub fn new(batch: usize, full: bool, scene: SceneFile, renderer: Renderer, io: Inbox) -> Switch {
        Switch {
            batch,
            full,
            keyframe_part_bytes: osw_wire::limits::KEYFRAME_PART_BYTES,
            adaptive: 0.0,
            payoff: None,
            next: None,
            scene,
            renderer,
            io,
            visible: Vec::new(),
            occluders: Vec::new(),
            seen: Vec::new(),
            peer_eof_received_us: 0,
            or_us: [0; 2],
        }
    }

    /// Waits for the display, the peer and the first camera. Camera 0 starts the path; a
    /// later one means this node restarted into a running cluster and rejoins it (asking
    /// again on a new connection of the peer). Returns the first frame to run, or `None` when
    /// the display said goodbye first.
    pub fn start(&mut self) -> anyhow::Result<Option<u64>> {
        self.io.connected()?;
        let Some(first) = self.io.first_camera("the first camera")? else { return Ok(None) };
        if self.io.roles.started(first) {
            return Ok(Some(0));
        }
        loop {
            match self.rejoin(0, false)? {
                Some(first) => return Ok(Some(first)),
                None if self.io.roles.display == Display::Done => return Ok(None),
                None if matches!(self.io.roles.peer, Peer::OutOfStep { .. }) => tracing::warn!("the peer connected anew: asking it again"),
                None => anyhow::bail!("the peer left before this node could rejoin"),
            }
        }
    }

    /// Runs frames from `first` until the display says goodbye, handing each frame's row to
    /// `log`.
    pub fn run(&mut self, first: u64, log: &mut dyn FnMut(&NodeFrame) -> anyhow::Result<()>) -> anyhow::Result<()> {
        let (mut i, mut cpu) = (first, osw_render::stats::cpu_ms());
        loop {
            self.io.drain();
            let f = match self.io.roles.step(i) {
                Step::Stop => return Ok(()),
                Step::StartOver => match self.start_over()? {
                    Some(first) => {
                        i = first;
                        continue;
                    }
                    None => return Ok(()),
                },
                Step::Rejoin => {
                    tracing::warn!("the link to the peer is back: rejoining it");
                    i = self.rejoin(i, true)?.unwrap_or(i);
                    continue;
                }
                Step::Frame(Duty::Or) => self.or(i)?,
                Step::Frame(_) => self.hc(i)?,
            };
            if let Some(mut f) = f {
                // All of this process's CPU time since the last frame: waits, sends and
                // lavapipe's threads included.
                let now = osw_render::stats::cpu_ms();
                (f.cpu_ms, cpu) = (now - cpu, now);
                i = f.frame + 1;
                log(&f)?;
            }
        }
    }

    /// HC for frame i, alone when no OR pass prepared camera i's depth buffer.
    fn hc(&mut self, i: u64) -> anyhow::Result<Option<NodeFrame>> {
        let newest_wins = !self.io.roles.peer_in_step();
        let Some((cam, camera_received_us)) = self.io.camera(i, newest_wins)? else { return Ok(None) };
        let (i, t, duty) = (cam.frame, Instant::now(), self.io.roles.duty(cam.frame));
        let mut or_us = std::mem::take(&mut self.or_us);
        let mut hc_start_us = now_us();
        self.io.sent = [0; 2];
        self.io.send_display(&Message::Camera(cam))?;
        // Decided when OR prepared this frame's depth buffer, or now.
        let cull = match self.next.take() {
            Some(next) if duty != Duty::Solo => next,
            _ => self.payoff.as_mut().is_none_or(Payoff::cull),
        };
        let r = &mut self.renderer;
        r.begin_frame();
        let view = r.view(&packet::camera(&cam), cam.tau_px);
        let mut f = NodeFrame { frame: i, duty, cull_skipped: u32::from(!cull), ..NodeFrame::default() };
        if duty == Duty::Solo && cull {
            // The OR pass of Yoon 2003 fig. 5 on this GPU: the front of V(i-1) for camera i.
            let t = Instant::now();
            or_us[0] = hc_start_us;
            let or =
                pass::or(r, &self.scene, &view, Occluders { ids: &self.visible, tau: cam.tau_px, load: Load::Clear }, &mut self.occluders)?;
            (f.nodes_drawn, f.or_ms, f.or_gpu_ms) = (or.nodes, ms(t), or.gpu_ms());
            hc_start_us = now_us();
            or_us[1] = hc_start_us;
        }
        let mut pvs = Vec::new();
        let hc = if cull {
            let opts = HcOptions { tau: cam.tau_px, adaptive: self.adaptive, ..HcOptions::default() };
            pass::hc(r, &self.scene, &view, opts, &self.visible, &mut self.seen, &mut pvs)?
        } else {
            // Frustum culled only: occlusion culling did not pay where this node last ran it.
            let stats = frustum_cull(self.scene.nodes(), &view, cam.tau_px, &mut pvs);
            pvs.sort_unstable();
            HcPass { stats, ..HcPass::default() }
        };
        let pyramid = hc.pyramid;
        let (hc, times) = (hc.stats, hc.times);
        (f.hc_traversal_ms, f.hc_second_look_ms, f.hc_retest_ms) = (times.traversal_ms, times.second_look_ms, times.retest_ms);
        // A frame without occluders (the first) culls nothing, whatever culling would save.
        if let Some(p) = self.payoff.as_mut().filter(|_| cull && !self.visible.is_empty()) {
            p.judge_hc(self.scene.nodes(), &hc, &pvs);
        }
        (f.batches, f.ids_sent) = self.send_visible_set(i, duty, &pvs)?;
        let hc_us = t.elapsed().as_micros() as u64;
        let passes_us = [times.traversal_ms, times.second_look_ms, times.retest_ms].map(|ms| (ms * 1e3) as u64);
        let degraded = self.io.roles.degraded(i);
        let stats =
            HcWireStats { tests: hc.tests, levels: hc.levels, hc_us, passes_us, pvs: pvs.len() as u32, cull_skipped: !cull, degraded };
        let peer_eof_received_us = self.peer_eof_received_us;
        let peer_sent_us = now_us();
        let eof = |sent_us| {
            let [or_start_us, or_end_us] = or_us;
            let clock = LinkStamps { sent_us, camera_received_us, peer_eof_received_us, peer_sent_us, or_start_us, or_end_us, hc_start_us };
            Message::EndOfFrame(EndOfFrame { frame: i, stats, clock })
        };
        self.io.send(&eof(peer_sent_us), self.io.roles.peer_in_step(), false)?;
        // HC's notes of V(i)'s clusters (pass::note_clusters) once the peer has its end of
        // frame: RVG draws only the visible ones.
        if let Some(p) = pyramid {
            if self.renderer.options().cluster_tests.occlusion {
                let bits = pass::note_clusters(&self.scene, &view, &pvs, &p)?.mask().to_vec();
                // A mask too large for a frame (about 130M clusters in view) is not sent: RVG
                // then draws the nodes whole.
                if bits.len() <= osw_wire::limits::KEYFRAME_PART_BYTES {
                    self.io.send(&Message::Clusters(ClusterMask { frame: i, bits }), false, true)?;
                }
            }
            self.renderer.give_back(p);
        }
        self.io.send(&eof(now_us()), false, true)?;
        if self.io.roles.hc_done(i) {
            for part in self.keyframe(i, &pvs) {
                self.io.send_peer(&part)?;
            }
            tracing::warn!("handed the peer V({i}): the switch resumes at frame {}", i + 2);
        }
        self.visible = pvs;
        [f.bytes_to_peer, f.bytes_to_display] = self.io.sent;
        (f.ms, f.tests, f.retests, f.rss_kb) = (ms(t), hc.tests, hc.retests, rss_kb());
        (f.auth_refusals, f.wire_bytes_sent) = (osw_wire::net::auth_refusals(), osw_wire::net::wire_bytes_sent());
        Ok(Some(f))
    }

    /// Streams V(i) as HC: to the peer when it is in step, as deltas in batches of b ids (or
    /// keyframes with `--full`); to RVG the same, or the whole set when it may not hold this
    /// node's V(i-1); a keyframe goes in parts, each within a frame. Returns the batches and
    /// the ids sent to RVG.
    fn send_visible_set(&mut self, i: u64, duty: Duty, pvs: &[NodeId]) -> Result<(u32, u64), osw_wire::WireError> {
        let to_peer = self.io.roles.peer_in_step();
        let keyframe_to_display = self.full || keyframe_to_display(i, duty);
        if keyframe_to_display || self.full {
            let parts = self.keyframe(i, pvs);
            for part in &parts {
                self.io.send(part, self.full && to_peer, keyframe_to_display)?;
            }
            if self.full {
                return Ok((parts.len() as u32, pvs.len() as u64));
            }
        }
        let (mut added, mut removed) = (Vec::new(), Vec::new());
        diff(&self.visible, pvs, &mut added, &mut removed);
        let (mut n, mut ids) = (0, if keyframe_to_display { pvs.len() as u64 } else { 0 });
        for (a, rm) in batches(&added, &removed, self.batch) {
            let delta = Message::Delta(Delta { frame: i, added: IdList::from_ids(a), removed: IdList::from_ids(rm) });
            if !keyframe_to_display {
                ids += (a.len() + rm.len()) as u64;
            }
            self.io.send(&delta, to_peer, !keyframe_to_display)?;
            n += 1;
        }
        Ok((n, ids))
    }

    /// V(i) as keyframe parts.
    fn keyframe(&self, i: u64, pvs: &[NodeId]) -> Vec<Message> {
        Keyframe::parts(i, pvs, self.keyframe_part_bytes)
    }

    /// OR in frame i (camera i+1) while the peer is HC for frame i. When the peer is lost
    /// before its end of frame, this node runs frame i alone instead.
    fn or(&mut self, i: u64) -> anyhow::Result<Option<NodeFrame>> {
        let Some((cam, _)) = self.io.camera(i + 1, false)? else { return Ok(None) };
        let (t, start_us) = (Instant::now(), now_us());
        let max_id = self.scene.header().node_count;
        self.renderer.begin_frame();
        let view = self.renderer.view(&packet::camera(&cam), cam.tau_px);
        // This node is HC of the next frame: whether it culls is decided now, from the last
        // frame it culled; when it does not, OR draws nothing, and only follows V(i).
        let cull = self.payoff.as_mut().is_none_or(Payoff::cull);
        let (mut drawn, mut or_ms) = (DrawStats::default(), 0.0);
        let scene = &self.scene;
        let mut or = |r: &mut Renderer, ids: &[NodeId], load: Load, scratch: &mut Vec<NodeId>| -> anyhow::Result<()> {
            if cull {
                let t = Instant::now();
                drawn = drawn + pass::or(r, scene, &view, Occluders { ids, tau: cam.tau_px, load }, scratch)?;
                or_ms += ms(t);
            }
            Ok(())
        };
        or(&mut self.renderer, &self.visible, Load::Clear, &mut self.occluders)?;
        let mut next = Assembly::default();
        loop {
            let Some((m, at)) = self.io.peer_message(i)? else {
                if self.io.roles.display != Display::Playing {
                    return Ok(None);
                }
                tracing::warn!("frame {i}: the peer is gone; running it alone");
                return self.hc(i);
            };
            let added = match m {
                Message::Delta(d) if d.frame == i => next.delta(d.added.ids(max_id)?, d.removed.ids(max_id)?),
                // The whole V(i): draw what V(i-1) lacks, as the deltas would have.
                Message::Keyframe(k) if k.frame == i => {
                    next.keyframe(&self.visible, k.part, k.parts, k.ids.ids(max_id)?).map_err(|e| anyhow::anyhow!("frame {i}: {e}"))?
                }
                Message::EndOfFrame(e) if e.frame == i => {
                    self.peer_eof_received_us = at;
                    break;
                }
                m => anyhow::bail!("frame {i}: unexpected message from the peer: {m:?}"),
            };
            or(&mut self.renderer, added, Load::Keep, &mut self.occluders)?;
        }
        self.next = Some(cull);
        self.visible = next.finish(&self.visible).map_err(|e| anyhow::anyhow!("frame {i}: {e}"))?;
        self.io.roles.or_done(i);
        self.or_us = [start_us, now_us()];
        let or_gpu_ms = drawn.gpu_ms();
        Ok(Some(NodeFrame {
            frame: i,
            duty: Duty::Or,
            ms: ms(t),
            or_ms,
            or_gpu_ms,
            nodes_drawn: drawn.nodes,
            rss_kb: rss_kb(),
            auth_refusals: osw_wire::net::auth_refusals(),
            wire_bytes_sent: osw_wire::net::wire_bytes_sent(),
            ..NodeFrame::default()
        }))
    }

    /// Asks the peer for its visible set and waits for it (failover, docs/switch.md); `next` is the first frame
    /// this node has not served. From the frame after the keyframe's this node is OR, the
    /// peer alone once more. Returns that frame, or `None` when the wait ends without one
    /// (see [`Roles::awaiting_keyframe`](crate::roles::Roles::awaiting_keyframe)); a
    /// `running` node then goes on alone rather than leave the display with neither.
    fn rejoin(&mut self, next: u64, running: bool) -> anyhow::Result<Option<u64>> {
        self.io.send_peer(&Message::Rejoin(Rejoin { next }))?;
        self.io.roles.asked();
        let deadline = Instant::now() + self.io.wait;
        loop {
            if let Some((frame, visible)) = self.io.keyframe(self.scene.header().node_count)? {
                self.visible = visible;
                let first = self.io.roles.rejoined(frame);
                tracing::warn!("rejoined at frame {first}");
                return Ok(Some(first));
            }
            if !self.io.roles.awaiting_keyframe(running) {
                return Ok(None);
            }
            match self.io.next_event("a keyframe from the peer", deadline) {
                Err(e) if running => {
                    tracing::warn!("{e}: going on alone");
                    return Ok(None);
                }
                r => r?,
            }
        }
    }

    /// A restarted display: forget the visible set (the display holds none) and run from its
    /// first camera; `None` when it said goodbye first.
    fn start_over(&mut self) -> anyhow::Result<Option<u64>> {
        self.io.start_over()?;
        // Everything a path carries from frame to frame: the new path's frame 0 is then what
        // a first run's is (prev's on the same cameras).
        self.visible.clear();
        self.seen.clear();
        self.next = None;
        if let Some(p) = &mut self.payoff {
            p.restart();
        }
        self.io.first_camera("the new display's first camera")
    }

    /// Tells everyone this node is leaving.
    pub fn goodbye(&mut self, reason: &str) {
        // A reason is a few words: it always fits a frame.
        let _ = self.io.send(&Message::Goodbye(Goodbye { reason: reason.to_owned() }), true, true);
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn rss_kb() -> u64 {
    osw_render::stats::resident_bytes() >> 10
}
