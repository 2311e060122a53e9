//! The messages (occlusion switch alg. 4.2 and sec. 3.4-3.5). Per frame i the HC node sends the
//! camera of frame i to RVG first, then deltas as it finds them, then end of frame; RVG sends
//! every camera to both nodes.

use crate::auth::{NONCE_BYTES, TAG_BYTES};
use crate::error::WireError;
use crate::limits::{MAX_NAME_BYTES, MAX_SETTINGS};
use serde::{Deserialize, Serialize};

/// What a peer is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Role {
    /// A switch node (OR / HC).
    Node,
    /// The display client (RVG).
    Display,
}

/// The first message on every connection, both ways: the protocol spoken and a fresh nonce
/// ([`crate::auth`]). Nothing else is said before the peer has proved it holds the token.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Challenge {
    pub version: u32,
    pub nonce: [u8; NONCE_BYTES],
}

/// The second message, both ways: the sender's proof that it holds the cluster token, over
/// its nonce and the receiver's ([`crate::auth`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Proof {
    pub tag: [u8; TAG_BYTES],
}

/// The third message, both ways, once the peer's proof has checked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Hello {
    pub version: u32,
    /// Content hash of the scene file: every process must hold the same scene.
    pub scene_hash: [u64; 2],
    pub name: String,
    pub role: Role,
    /// A node that has run frames (it holds a visible set), not one just started: a running
    /// node asks a serving peer to rejoin when their link comes back, and a started one waits
    /// for it to ask.
    pub serving: bool,
    /// The settings every process of the cluster must share, as (flag, value): the handshake
    /// refuses a peer that says another value or another set of settings.
    pub settings: Vec<(String, String)>,
    /// A display's session: when it started (its wall clock, µs), so that a display started
    /// later has a larger one and a display reconnecting keeps its own; 0 for a node.
    pub session: u64,
    /// The HMAC of this hello (with a zero tag) under the token and both nonces
    /// ([`crate::auth::Purpose::Hello`]).
    pub tag: [u8; TAG_BYTES],
}

impl Hello {
    /// This build's greeting for a process holding the scene `scene_hash` with `settings`: not
    /// serving yet.
    pub fn new(scene_hash: [u64; 2], name: impl Into<String>, role: Role, settings: Vec<(String, String)>) -> Hello {
        Hello {
            version: crate::limits::PROTOCOL_VERSION,
            scene_hash,
            name: name.into(),
            role,
            serving: false,
            settings,
            session: 0,
            tag: [0; TAG_BYTES],
        }
    }

    /// Why `peer`'s settings are not these, naming the first that differs.
    pub fn disagreement(&self, peer: &Hello) -> Option<String> {
        let theirs = |k: &str| peer.settings.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str());
        for (k, v) in &self.settings {
            match theirs(k) {
                Some(t) if t == v => {}
                Some(t) => return Some(format!("setting {k}: {t} there, {v} here")),
                None => return Some(format!("setting {k}: not said there, {v} here")),
            }
        }
        let mine = |k: &str| self.settings.iter().any(|(n, _)| n == k);
        peer.settings.iter().find(|(k, _)| !mine(k)).map(|(k, t)| format!("setting {k}: {t} there, not said here"))
    }
}

/// A camera: 80 bytes of fields (the paper counts 72; we add the sample time for latency).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraPacket {
    pub frame: u64,
    /// World position (f64: scenes far from the origin).
    pub position: [f64; 3],
    /// Unit quaternion x, y, z, w.
    pub orientation: [f64; 4],
    pub fovy_deg: f64,
    /// Pixels of error allowed by LOD selection for this frame: set by RVG (changed
    /// interactively), so that both nodes select the same LODs for the same frame.
    pub tau_px: f64,
    /// When RVG sampled this camera ([`crate::clock::now_us`] on RVG's host).
    pub sampled_us: u64,
}

/// Sorted node ids, coded by [`crate::ids`].
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct IdList(pub Vec<u8>);

impl IdList {
    pub fn from_ids(ids: &[u32]) -> IdList {
        let mut b = Vec::with_capacity(ids.len() * 2);
        crate::ids::encode(ids, &mut b);
        IdList(b)
    }

    /// The ids, each checked to be below `max_id`.
    pub fn ids(&self, max_id: u32) -> Result<Vec<u32>, WireError> {
        crate::ids::decode(&self.0, max_id)
    }
}

/// Part of frame `frame`'s visible-set change (one batch of at most b ids).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Delta {
    pub frame: u64,
    pub added: IdList,
    pub removed: IdList,
}

/// HC's statistics of one frame, sent with its end.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HcWireStats {
    pub tests: u32,
    pub levels: u32,
    /// The HC node's time on the frame, and HC's three passes in it (traversal, second look,
    /// retest).
    pub hc_us: u64,
    pub passes_us: [u64; 3],
    pub pvs: u32,
    /// The frame was frustum culled only: occlusion culling did not pay where it last ran.
    pub cull_skipped: bool,
    /// A degraded frame, whose V(i) prev's may not match: the HC node ran both roles for it
    /// (its peer gone or not in step), or the nodes were still recovering from a rejoin.
    pub degraded: bool,
}

/// The end of frame `frame` (the paper's sentinel).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EndOfFrame {
    pub frame: u64,
    pub stats: HcWireStats,
    pub clock: LinkStamps,
}

/// The HC node's wall-clock stamps ([`crate::clock::now_us`] on its host) from which the
/// display computes each link's one-way latency; 0 where there is none.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LinkStamps {
    /// When this end of frame was sent (HC → RVG, or HC → OR for the peer's copy).
    pub sent_us: u64,
    /// When this node received the frame's camera from RVG (RVG → HC).
    pub camera_received_us: u64,
    /// When this node, as OR, received the peer's end of the previous frame (HC → OR).
    pub peer_eof_received_us: u64,
    /// When this frame's end went to the peer (HC → OR; protocol 11): before HC's cluster
    /// notes, which RVG's end of frame waits for.
    pub peer_sent_us: u64,
    /// The stages the frame's camera went through on this node (protocol 13): when OR took
    /// it and began drawing V(i-1) (a frame run alone: its own OR pass), when OR ended (the
    /// peer's V(i) drawn), and when HC began.
    pub or_start_us: u64,
    pub or_end_us: u64,
    pub hc_start_us: u64,
}

/// HC's notes of which clusters of V(`frame`) are visible (osw_cull::cluster::VisibleClusters):
/// per node of V(`frame`) in id order, a bit per opaque cluster of its block, 0 where HC found
/// the cluster hidden. HC sends it to RVG only, before the end of frame; RVG draws a frame
/// without one whole. Not in the paper, whose wire carries node ids only: about a bit per
/// cluster in view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClusterMask {
    pub frame: u64,
    pub bits: Vec<u8>,
}

/// Clock probe, display to node: the node answers with a [`Pong`] at once.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ping {
    pub sent_us: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pong {
    pub ping_sent_us: u64,
    pub received_us: u64,
    pub sent_us: u64,
}

/// Part `part` of `parts` of the whole visible set of frame `frame`: at start-up and to
/// resynchronise. The parts go in order, each a run of the sorted ids.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Keyframe {
    pub frame: u64,
    pub part: u32,
    pub parts: u32,
    pub ids: IdList,
}

impl Keyframe {
    /// V(`frame`) = `ids` (sorted) as keyframe parts, each coding its ids in at most
    /// `max_bytes` ([`crate::limits::KEYFRAME_PART_BYTES`] on the wire). An empty set is one
    /// empty part.
    pub fn parts(frame: u64, ids: &[u32], max_bytes: usize) -> Vec<Message> {
        let mut runs = crate::ids::split(ids, max_bytes);
        if runs.is_empty() {
            runs.push(ids);
        }
        let parts = runs.len() as u32;
        runs.iter()
            .enumerate()
            .map(|(k, r)| Message::Keyframe(Keyframe { frame, part: k as u32, parts, ids: IdList::from_ids(r) }))
            .collect()
    }
}

/// What a rejoining node has served: the peer hands over V(i) at the end of a frame i with
/// i + 1 >= `next`, so that the display, which may hold frames up to `next` - 1 from the
/// asking node, gets every frame from i + 1 on from one visible set (the peer's frame i + 1 is
/// a keyframe to the display).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rejoin {
    /// The first frame the asking node has not served (0 after a restart).
    pub next: u64,
}

/// The sender follows a display's path (RVG) from here: what it sends its peer from here on
/// belongs to that display's path, and anything before it to another's. Sent when the sender
/// starts a display's path, and first on a new connection to the peer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StartOver {
    /// The display session whose path the sender follows from here ([`Hello::session`]).
    pub session: u64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Goodbye {
    pub reason: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Message {
    Hello(Hello),
    Camera(CameraPacket),
    Delta(Delta),
    EndOfFrame(EndOfFrame),
    Keyframe(Keyframe),
    Goodbye(Goodbye),
    Ping(Ping),
    Pong(Pong),
    /// Sent by a connection's writer when it has had nothing to send for a while, so that a
    /// silent peer (a cut network) is noticed within [`crate::limits::SILENCE`].
    Heartbeat,
    /// A node asks its peer, running both roles alone, for a keyframe: after a restart, or
    /// when the link between them is back after a cut.
    Rejoin(Rejoin),
    StartOver(StartOver),
    Clusters(ClusterMask),
    Challenge(Challenge),
    Proof(Proof),
}

impl Message {
    /// The frame a frame's message belongs to (camera, visible set, cluster mask, end of frame).
    pub fn frame(&self) -> Option<u64> {
        match self {
            Message::Camera(c) => Some(c.frame),
            Message::Delta(d) => Some(d.frame),
            Message::Keyframe(k) => Some(k.frame),
            Message::EndOfFrame(e) => Some(e.frame),
            Message::Clusters(c) => Some(c.frame),
            _ => None,
        }
    }

    /// Checks what bincode cannot: finite cameras with a usable field of view, bounded names.
    pub fn validate(&self) -> Result<(), WireError> {
        match self {
            Message::Camera(c) => {
                let finite = c.position.iter().chain(&c.orientation).all(|v| v.is_finite()) && c.fovy_deg.is_finite();
                let q = c.orientation.iter().map(|v| v * v).sum::<f64>().sqrt();
                // q overflows to infinity for huge finite components: refused too.
                let orientation_ok = q >= 1e-6 && q.is_finite();
                let fovy_ok = c.fovy_deg > 0.0 && c.fovy_deg < 180.0;
                let tau_ok = c.tau_px.is_finite() && c.tau_px >= 0.0;
                if !(finite && orientation_ok && fovy_ok && tau_ok) {
                    return Err(WireError::BadCamera(format!(
                        "frame {}: position {:?}, orientation {:?}, fovy {}, tau {}",
                        c.frame, c.position, c.orientation, c.fovy_deg, c.tau_px
                    )));
                }
            }
            Message::Keyframe(k) if k.part >= k.parts => {
                return Err(WireError::Malformed(format!("keyframe part {} of {}", k.part, k.parts)));
            }
            Message::Hello(h)
                if h.name.len() > MAX_NAME_BYTES
                    || h.settings.len() > MAX_SETTINGS
                    || h.settings.iter().any(|(k, v)| k.len() + v.len() > MAX_NAME_BYTES) =>
            {
                return Err(WireError::Malformed("hello: name or settings too long".into()));
            }
            _ => {}
        }
        Ok(())
    }
}
