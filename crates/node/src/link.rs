//! The node's connections: a listener for the display and the peer, and for node b a
//! connection to node a that is made again whenever it ends (node a restarted). Each
//! connection has a reader feeding [`Event`]s to the frame loop and a writer draining a queue
//! of its own, so the frame loop never waits on the network to send, and a dead connection's
//! queue goes with it.

use osw_wire::auth::Token;
use osw_wire::limits::HANDSHAKE;
use osw_wire::messages::{Hello, Message, Role};
use osw_wire::net::{End, conn, handshake, run_connection};
use osw_wire::tls::Tls;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::Sender;
use std::time::Duration;
use tokio::sync::mpsc::UnboundedSender;

/// What the frame loop hears. Messages carry their arrival time
/// ([`osw_wire::clock::now_us`]) for the display's per-link latency; connections carry an id
/// so that the end of an old connection is not taken for the end of its replacement.
#[derive(Debug)]
pub enum Event {
    /// `serving` and `session`: the peer's [`Hello::serving`] and [`Hello::session`].
    Connected {
        role: Role,
        name: String,
        serving: bool,
        session: u64,
        id: u64,
        out: UnboundedSender<osw_wire::Frame>,
    },
    /// A message from the display, its arrival time and the connection it came on (`id` of
    /// its [`Event::Connected`]).
    FromDisplay(Message, u64, u64),
    FromPeer(Message, u64),
    Closed {
        role: Role,
        id: u64,
        why: String,
    },
}

/// Most cameras from the display waiting for the frame loop. Playback needs three (k-1 in
/// case of a takeover, k, k+1); more is a display sending faster than frames are made.
pub const MAX_CAMERAS: usize = 8;

/// Bounds the display's cameras between the connection and the frame loop: the camera
/// receiver of occlusion switch sec. 4.8.1 keeps only what the frame loop can use, so a flood of
/// cameras is dropped as it arrives and counted, and fills neither memory nor the event queue
/// (which the peer's messages share), however far the frame loop falls behind. It drops
/// only when MAX_CAMERAS arrive within one frame's work; a display sends one a frame.
#[derive(Default)]
pub struct CameraGate {
    waiting: AtomicUsize,
    dropped: AtomicU64,
}

impl CameraGate {
    /// A camera arrived: whether it may join the queue.
    fn admit(&self) -> bool {
        if self.waiting.fetch_add(1, Ordering::AcqRel) >= MAX_CAMERAS {
            self.waiting.fetch_sub(1, Ordering::AcqRel);
            self.dropped.fetch_add(1, Ordering::Relaxed);
            return false;
        }
        true
    }

    /// The frame loop took a camera off the queue.
    pub fn taken(&self) {
        self.waiting.fetch_sub(1, Ordering::AcqRel);
    }

    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// This node's hello, said at each handshake with whether it serves frames by then.
#[derive(Clone)]
pub struct Me {
    pub hello: Hello,
    /// The cluster token it proves it holds (osw_wire::auth).
    pub token: Option<Arc<Token>>,
    /// Mutual TLS on every link, where the cluster has it (osw_wire::tls).
    pub tls: Option<Tls>,
    pub serving: Arc<AtomicBool>,
}

/// Runs a connection: handshake, then messages to `events` (the display's cameras through
/// `gate`) until it ends.
pub async fn serve(c: osw_wire::net::Conn, me: Me, events: Sender<Event>, gate: Arc<CameraGate>) {
    let mut c = c;
    let token = me.token.clone();
    let me = Hello { serving: me.serving.load(Ordering::Acquire), ..me.hello };
    let peer = match handshake(&mut c, &me, token.as_deref(), HANDSHAKE).await {
        Ok(h) => h,
        Err(e) => {
            tracing::warn!("{}: {e}", me.name);
            return;
        }
    };
    let (role, id) = (peer.role, NEXT_ID.fetch_add(1, Ordering::Relaxed));
    let (out, queue) = tokio::sync::mpsc::unbounded_channel();
    if events.send(Event::Connected { role, name: peer.name.clone(), serving: peer.serving, session: peer.session, id, out }).is_err() {
        return;
    }
    let why = run_connection(c, queue, |m, at, _| match role {
        Role::Display if matches!(m, Message::Camera(_)) && !gate.admit() => true,
        Role::Display => events.send(Event::FromDisplay(m, at, id)).is_ok(),
        Role::Node => events.send(Event::FromPeer(m, at)).is_ok(),
    })
    .await;
    let who = match role {
        Role::Node => format!("node {}", peer.name),
        Role::Display => peer.name.clone(),
    };
    let _ = events.send(Event::Closed { role, id, why: format!("{who}: {why}") });
}

/// Accepts connections on `listener` forever, serving each.
pub async fn accept(listener: tokio::net::TcpListener, me: Me, events: Sender<Event>, gate: Arc<CameraGate>) {
    loop {
        match listener.accept().await {
            Ok((s, _)) => {
                let (me, events, gate) = (me.clone(), events.clone(), Arc::clone(&gate));
                tokio::spawn(async move {
                    match conn(s, me.tls.as_ref(), End::Accepted, HANDSHAKE).await {
                        Ok(c) => serve(c, me, events, gate).await,
                        Err(e) => tracing::warn!("{}: {e}", me.hello.name),
                    }
                });
            }
            Err(e) => tracing::warn!("accept: {e}"),
        }
    }
}

/// Node b's side of the peer link: connects to `addr` (retrying with backoff) and connects
/// again whenever the connection ends, for as long as the process runs.
pub async fn keep_connected(addr: String, me: Me, events: Sender<Event>, gate: Arc<CameraGate>) {
    loop {
        match osw_wire::net::connect(&addr, Duration::from_secs(3600), me.tls.as_ref()).await {
            Ok(c) => serve(c, me.clone(), events.clone(), Arc::clone(&gate)).await,
            Err(e) => tracing::warn!("{}: {e}", me.hello.name),
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gate_holds_at_most_max_cameras_and_counts_the_rest() {
        let g = CameraGate::default();
        let admitted = (0..1000).filter(|_| g.admit()).count();
        assert_eq!((admitted, g.dropped()), (MAX_CAMERAS, 1000 - MAX_CAMERAS as u64));
        // The frame loop takes two: two more get in.
        g.taken();
        g.taken();
        assert!(g.admit() && g.admit() && !g.admit());
        assert_eq!(g.dropped(), 1001 - MAX_CAMERAS as u64);
    }
}
