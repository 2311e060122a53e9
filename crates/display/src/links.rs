//! The display's connections to the two nodes: each is made (handshake, clock probes), run
//! until it fails or falls silent, and made again with backoff, for as long as the display
//! runs. What happens on them reaches the frame loop as [`Note`]s on one channel, so that it
//! reads whichever node has the frame (failover: a node lost, a node rejoining).

use osw_wire::auth::Token;
use osw_wire::clock::Offset;
use osw_wire::messages::{Hello, Message};
use osw_wire::net::{NetError, connect, handshake, probe_clock, run_connection};
use osw_wire::{Frame, WireError};
use std::sync::mpsc::Sender;
use std::time::Duration;
use tokio::sync::mpsc::UnboundedSender;

/// Clock probes per connection (the least round trip of them is used).
const CLOCK_PROBES: usize = 16;

pub const NAMES: [&str; 2] = ["a", "b"];

#[derive(Debug)]
pub enum Note {
    /// Node `node` is connected: send to it through `out`; its clock is `clock`.
    Up { node: usize, out: UnboundedSender<Frame>, clock: Offset },
    /// A message from node `node`, its frame bytes and arrival time.
    Message { node: usize, m: Message, bytes: u64, at: u64 },
    /// Node `node`'s connection failed or ended (or could not be made: `ever_up` false).
    Down { node: usize, why: String, ever_up: bool },
}

/// What the display says of itself at each handshake, and the cluster token it proves it holds.
pub struct Me {
    pub hello: Hello,
    pub token: Option<Token>,
    pub tls: Option<osw_wire::tls::Tls>,
}

/// Keeps node `node` at `addr` connected: the first connection is tried for `first_within`,
/// later ones for as long as the display runs.
pub async fn keep_node(node: usize, addr: String, me: Me, notes: Sender<Note>, first_within: Duration) {
    let mut ever_up = false;
    let start = std::time::Instant::now();
    loop {
        let attempt = async {
            let within = if ever_up { Duration::from_secs(3600) } else { first_within.saturating_sub(start.elapsed()) };
            let mut c = connect(&addr, within, me.tls.as_ref()).await?;
            handshake(&mut c, &me.hello, me.token.as_ref(), Duration::from_secs(10)).await?;
            let clock = probe_clock(&mut c, CLOCK_PROBES, Duration::from_secs(10)).await?;
            Ok::<_, osw_wire::net::NetError>((c, clock))
        };
        let why = match attempt.await {
            Ok((c, clock)) => {
                let (out, queue) = tokio::sync::mpsc::unbounded_channel();
                if notes.send(Note::Up { node, out, clock }).is_err() {
                    return;
                }
                ever_up = true;
                run_connection(c, queue, |m, at, bytes| notes.send(Note::Message { node, m, bytes: bytes as u64, at }).is_ok()).await
            }
            // Before the node was ever up, a connection closed during the handshake (a relay
            // or proxy with no node behind it yet) is tried again while the start-up wait
            // lasts; a refusal (another protocol, scene or token) is final.
            Err(e) if !ever_up && !matches!(e, NetError::Refused { .. }) && start.elapsed() < first_within => {
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
            Err(e) => e.to_string(),
        };
        if notes.send(Note::Down { node, why: format!("node {}: {why}", NAMES[node]), ever_up }).is_err() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// What the frame loop knows of the nodes.
#[derive(Default)]
pub struct Cluster {
    /// Where to send to each node while it is connected.
    pub nodes: [Option<UnboundedSender<Frame>>; 2],
    pub clocks: [Offset; 2],
    ever_up: [bool; 2],
    /// The last two cameras sent: a node that reconnects gets them.
    recent: std::collections::VecDeque<Frame>,
    pub losses: u32,
    pub rejoins: u32,
}

impl Cluster {
    /// Takes in a note; returns the message it carries, if any. A node that could not be
    /// reached at start-up is an error; one lost later is logged, counted and waited for.
    pub fn note(&mut self, n: Note) -> anyhow::Result<Option<(usize, Message, u64, u64)>> {
        match n {
            Note::Up { node, out, clock } => {
                if self.ever_up[node] {
                    self.rejoins += 1;
                    tracing::warn!("node {} is back", NAMES[node]);
                    self.recent.iter().for_each(|m| drop(out.send(m.clone())));
                }
                self.ever_up[node] = true;
                self.nodes[node] = Some(out);
                self.clocks[node] = clock;
                Ok(None)
            }
            Note::Down { why, ever_up: false, .. } => anyhow::bail!("{why}"),
            Note::Down { node, why, .. } => {
                if self.nodes[node].take().is_some() {
                    self.losses += 1;
                    tracing::warn!("{why}: frames come from node {} alone until it is back", NAMES[1 - node]);
                }
                Ok(None)
            }
            // A node leaving says why; its connection's end follows.
            Note::Message { node, m: Message::Goodbye(g), .. } => {
                tracing::warn!("node {} leaves: {}", NAMES[node], g.reason);
                Ok(None)
            }
            Note::Message { node, m, bytes, at } => Ok(Some((node, m, bytes, at))),
        }
    }

    pub fn send_camera(&mut self, m: &Message) -> Result<(), WireError> {
        let f = Frame::new(m)?;
        self.recent.push_back(f.clone());
        if self.recent.len() > 2 {
            self.recent.pop_front();
        }
        self.send_all(f);
        Ok(())
    }

    pub fn send_all(&self, f: Frame) {
        self.nodes.iter().flatten().for_each(|n| drop(n.send(f.clone())));
    }
}
