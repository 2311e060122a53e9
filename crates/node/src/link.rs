//! The node's connections: a listener for the display and the peer (or a connection to the
//! peer), one reader and one writer task per connection. Readers turn messages into
//! [`Event`]s for the frame loop; writers drain an unbounded queue, so the frame loop never
//! waits on the network to send.

use futures_util::{SinkExt, StreamExt};
use osw_wire::clock::now_us;
use osw_wire::messages::{Hello, Message, Pong, Role};
use osw_wire::net::{conn, handshake};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender};

/// What the frame loop hears. Messages carry their arrival time ([`now_us`]) for the
/// display's per-link latency.
#[derive(Debug)]
pub enum Event {
    Connected(Role, String),
    FromDisplay(Message, u64),
    FromPeer(Message, u64),
    /// A connection ended or failed; the frame loop decides whether that ends the run.
    Closed(Role, String),
}

/// The receiving ends of the send queues (peer, display), each taken by the one connection of
/// that role: a second display or peer is refused.
pub type Queues = Arc<Mutex<(Option<UnboundedReceiver<Message>>, Option<UnboundedReceiver<Message>>)>>;

/// Makes the send queues: senders for the frame loop, receivers for the connections.
pub fn queues() -> (UnboundedSender<Message>, UnboundedSender<Message>, Queues) {
    let (to_peer, peer_rx) = tokio::sync::mpsc::unbounded_channel();
    let (to_display, display_rx) = tokio::sync::mpsc::unbounded_channel();
    (to_peer, to_display, Arc::new(Mutex::new((Some(peer_rx), Some(display_rx)))))
}

pub const HANDSHAKE: Duration = Duration::from_secs(10);

/// Runs a connection: handshake, then a reader feeding `events` and a writer draining `out`.
pub async fn serve(c: osw_wire::net::Conn, me: Hello, events: Sender<Event>, queues: Queues) {
    let mut c = c;
    let peer = match handshake(&mut c, &me, HANDSHAKE).await {
        Ok(h) => h,
        Err(e) => {
            tracing::warn!("{}: {e}", me.name);
            return;
        }
    };
    let role = peer.role;
    let taken = {
        let mut q = queues.lock().unwrap_or_else(|p| p.into_inner());
        match role {
            Role::Node => q.0.take(),
            Role::Display => q.1.take(),
        }
    };
    let Some(out) = taken else {
        tracing::warn!("{}: refused a second {role:?} connection from {}", me.name, peer.name);
        return;
    };
    let _ = events.send(Event::Connected(role, peer.name.clone()));
    let (mut sink, mut stream) = c.split();
    let who = match role {
        Role::Node => format!("node {}", peer.name),
        Role::Display => peer.name.clone(),
    };
    // Clock probes are answered by the connection itself, ahead of queued frame traffic, so
    // that the frame loop's pace does not enter the round trip.
    let (pong_tx, mut pong_rx) = tokio::sync::mpsc::unbounded_channel::<Pong>();
    let writer = tokio::spawn(async move {
        let mut out = out;
        loop {
            let m = tokio::select! {
                biased;
                Some(p) = pong_rx.recv() => Message::Pong(Pong { sent_us: now_us(), ..p }),
                m = out.recv() => match m {
                    Some(m) => m,
                    None => break,
                },
            };
            if sink.send(m).await.is_err() {
                break;
            }
        }
    });
    let reason = loop {
        match stream.next().await {
            Some(Ok(Message::Ping(p))) => {
                let _ = pong_tx.send(Pong { ping_sent_us: p.sent_us, received_us: now_us(), sent_us: 0 });
            }
            Some(Ok(m)) => {
                let at = now_us();
                let e = match role {
                    Role::Node => Event::FromPeer(m, at),
                    Role::Display => Event::FromDisplay(m, at),
                };
                if events.send(e).is_err() {
                    break "frame loop ended".to_string();
                }
            }
            Some(Err(e)) => break format!("{who}: {e}"),
            None => break format!("{who} closed the connection"),
        }
    };
    writer.abort();
    let _ = events.send(Event::Closed(role, reason));
}

/// Accepts connections on `listener` forever, serving each.
pub async fn accept(listener: tokio::net::TcpListener, me: Hello, events: Sender<Event>, queues: Queues) {
    loop {
        match listener.accept().await {
            Ok((s, _)) => {
                tokio::spawn(serve(conn(s), me.clone(), events.clone(), queues.clone()));
            }
            Err(e) => tracing::warn!("accept: {e}"),
        }
    }
}
