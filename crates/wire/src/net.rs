//! Connections: TCP with TCP_NODELAY, frames through [`WireCodec`], and the handshake that
//! refuses a peer without the cluster token ([`crate::auth`]), with another protocol version,
//! another scene or other settings.

use crate::auth::{self, Purpose, TAG_BYTES, Token, nonce};
use crate::codec::{CodecError, WireCodec};
use crate::frame::Frame;
use crate::limits::PROTOCOL_VERSION;
use crate::messages::{Challenge, Hello, Message, Proof};
use crate::tls::Tls;
use futures_util::{SinkExt, StreamExt};
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::net::TcpStream;
use tokio_util::codec::Framed;

pub type Conn = Framed<Stream, WireCodec>;

/// A connection's byte stream: plain TCP, or TLS over it ([`crate::tls`]).
pub enum Stream {
    Plain(Counted),
    Tls(Box<tokio_rustls::TlsStream<Counted>>),
}

impl Stream {
    /// The peer's address, for messages.
    pub fn peer(&self) -> String {
        let tcp = match self {
            Stream::Plain(s) => &s.0,
            Stream::Tls(s) => &s.get_ref().0.0,
        };
        tcp.peer_addr().map(|a| a.to_string()).unwrap_or_else(|_| "peer".into())
    }

    fn io(self: Pin<&mut Self>) -> Pin<&mut (dyn Io + Send)> {
        match self.get_mut() {
            Stream::Plain(s) => Pin::new(s),
            Stream::Tls(s) => Pin::new(s.as_mut()),
        }
    }
}

/// A byte stream both ways.
trait Io: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin {}
impl<T: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin> Io for T {}

impl tokio::io::AsyncRead for Stream {
    fn poll_read(self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut tokio::io::ReadBuf<'_>) -> Poll<std::io::Result<()>> {
        self.io().poll_read(cx, buf)
    }
}

impl tokio::io::AsyncWrite for Stream {
    fn poll_write(self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        self.io().poll_write(cx, buf)
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        self.io().poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        self.io().poll_shutdown(cx)
    }
}

/// Bytes this process has written to its connections' sockets: TLS records as sent, without
/// TCP's and IP's headers.
static WIRE_BYTES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Bytes this process has written to its connections' sockets ([`Counted`]).
pub fn wire_bytes_sent() -> u64 {
    WIRE_BYTES.load(std::sync::atomic::Ordering::Relaxed)
}

/// A socket whose writes are counted in [`wire_bytes_sent`].
pub struct Counted(TcpStream);

impl tokio::io::AsyncRead for Counted {
    fn poll_read(self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut tokio::io::ReadBuf<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.get_mut().0).poll_read(cx, buf)
    }
}

impl tokio::io::AsyncWrite for Counted {
    fn poll_write(self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        let r = Pin::new(&mut self.get_mut().0).poll_write(cx, buf);
        if let Poll::Ready(Ok(n)) = &r {
            WIRE_BYTES.fetch_add(*n as u64, std::sync::atomic::Ordering::Relaxed);
        }
        r
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.get_mut().0).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.get_mut().0).poll_shutdown(cx)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum NetError {
    #[error(transparent)]
    Codec(#[from] CodecError),
    #[error("connection closed by {0}")]
    Closed(String),
    #[error("refused {peer}: {why}")]
    Refused { peer: String, why: String },
    #[error("{0}")]
    Timeout(String),
    #[error("cannot connect to {addr}: {source}")]
    Connect { addr: String, source: std::io::Error },
}

/// Which end of a connection a process is: the one that accepted it or the one that made it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    Accepted,
    Made,
}

/// Wraps a connected socket, in TLS where `tls` is given (its handshake within `within`): a
/// peer whose certificate the cluster's CA did not sign is refused before any osw byte.
pub async fn conn(stream: TcpStream, tls: Option<&Tls>, end: End, within: Duration) -> Result<Conn, NetError> {
    // Small messages (cameras, end of frame) must not wait for Nagle's algorithm.
    let _ = stream.set_nodelay(true);
    let peer = stream.peer_addr().map(|a| a.to_string()).unwrap_or_else(|_| "peer".into());
    let stream = Counted(stream);
    let Some(tls) = tls else { return Ok(Framed::new(Stream::Plain(stream), WireCodec)) };
    let secured = async {
        Ok::<_, std::io::Error>(match end {
            End::Accepted => tokio_rustls::TlsAcceptor::from(Arc::clone(&tls.server)).accept(stream).await?.into(),
            End::Made => tokio_rustls::TlsConnector::from(Arc::clone(&tls.client)).connect(Tls::server_name(), stream).await?.into(),
        })
    };
    match tokio::time::timeout(within, secured).await {
        Ok(Ok(s)) => Ok(Framed::new(Stream::Tls(Box::new(s)), WireCodec)),
        Ok(Err(e)) => Err(NetError::Refused { peer, why: format!("TLS: {e}") }),
        Err(_) => Err(NetError::Timeout(format!("no TLS handshake with {peer} within {within:?}"))),
    }
}

/// Connects to `addr`, retrying with backoff (50 ms doubling to 1 s) until `within` passes, in
/// TLS where `tls` is given (its handshake within [`crate::limits::HANDSHAKE`]).
pub async fn connect(addr: &str, within: Duration, tls: Option<&Tls>) -> Result<Conn, NetError> {
    let deadline = tokio::time::Instant::now() + within;
    let mut wait = Duration::from_millis(50);
    loop {
        match TcpStream::connect(addr).await {
            Ok(s) => return conn(s, tls, End::Made, crate::limits::HANDSHAKE).await,
            Err(e) if tokio::time::Instant::now() + wait > deadline => return Err(NetError::Connect { addr: addr.to_owned(), source: e }),
            Err(_) => {
                tokio::time::sleep(wait).await;
                wait = (wait * 2).min(Duration::from_secs(1));
            }
        }
    }
}

pub async fn send(c: &mut Conn, msg: &Message) -> Result<(), NetError> {
    Ok(c.send(msg.clone()).await?)
}

/// The next message; `Closed` at a clean end of stream.
pub async fn recv(c: &mut Conn, who: &str) -> Result<Message, NetError> {
    match c.next().await {
        Some(r) => Ok(r?.0),
        None => Err(NetError::Closed(who.to_owned())),
    }
}

/// How long a process waits before it drops a peer whose proof failed: a fixed delay, so that
/// guessing tokens over many connections is slow.
pub const REFUSAL_DELAY: Duration = Duration::from_millis(250);

/// Peers this process refused for a wrong proof of the token.
static AUTH_REFUSALS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Peers this process refused for a wrong proof of the token ([`handshake`]).
pub fn auth_refusals() -> u64 {
    AUTH_REFUSALS.load(std::sync::atomic::Ordering::Relaxed)
}

/// The handshake ([`crate::auth`]): nonces both ways, then proofs of `token` both ways, and
/// only once the peer's proof checks, hellos (each tagged under both nonces). The peer's hello
/// must speak the same protocol version, hold the same scene and run with the same settings.
/// Each step waits at most `within` for the peer.
pub async fn handshake(c: &mut Conn, me: &Hello, token: Option<&Token>, within: Duration) -> Result<Hello, NetError> {
    let peer = c.get_ref().peer();
    let refuse = |peer: &str, why: String| Err(NetError::Refused { peer: peer.to_owned(), why });
    let mine = nonce();
    send(c, &Message::Challenge(Challenge { version: PROTOCOL_VERSION, nonce: mine })).await?;
    let theirs = match next(c, &peer, within, "a challenge").await? {
        Message::Challenge(ch) if ch.version == PROTOCOL_VERSION => ch.nonce,
        Message::Challenge(ch) => return refuse(&peer, format!("protocol version {} (this build speaks {PROTOCOL_VERSION})", ch.version)),
        _ => return refuse(&peer, "the first message was not a challenge (another protocol version?)".into()),
    };
    send(c, &Message::Proof(Proof { tag: auth::tag(token, Purpose::Proof, &mine, &theirs, &[]) })).await?;
    let proved = match next(c, &peer, within, "a proof").await? {
        Message::Proof(p) => auth::verify(token, Purpose::Proof, &theirs, &mine, &[], &p.tag),
        _ => false,
    };
    if !proved {
        AUTH_REFUSALS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        tokio::time::sleep(REFUSAL_DELAY).await;
        return refuse(
            &peer,
            if token.is_some() { "a wrong or missing cluster token" } else { "a cluster token this process was not given" }.into(),
        );
    }
    let tag = auth::tag(token, Purpose::Hello, &mine, &theirs, untagged(me).bytes());
    send(c, &Message::Hello(Hello { tag, ..me.clone() })).await?;
    let Message::Hello(h) = next(c, &peer, within, "a hello").await? else {
        return refuse(&peer, "the message after its proof was not a hello".into());
    };
    if !auth::verify(token, Purpose::Hello, &theirs, &mine, untagged(&h).bytes(), &h.tag) {
        return refuse(&peer, "its hello does not carry its tag (changed on the way?)".into());
    }
    let peer = format!("{} ({peer})", h.name);
    if h.version != PROTOCOL_VERSION {
        return refuse(&peer, format!("protocol version {} (this build speaks {PROTOCOL_VERSION})", h.version));
    }
    if h.scene_hash != me.scene_hash {
        return refuse(
            &peer,
            format!(
                "a different scene (content hash {:016x}{:016x}, ours {:016x}{:016x})",
                h.scene_hash[1], h.scene_hash[0], me.scene_hash[1], me.scene_hash[0]
            ),
        );
    }
    if let Some(why) = me.disagreement(&h) {
        return refuse(&peer, why);
    }
    Ok(h)
}

/// A hello's frame with a zero tag: what its tag covers.
fn untagged(h: &Hello) -> Frame {
    Frame::new(&Message::Hello(Hello { tag: [0; TAG_BYTES], ..h.clone() })).expect("a hello within the limits encodes")
}

/// The peer's next message within `within`; `what` names it in the error.
async fn next(c: &mut Conn, peer: &str, within: Duration, what: &str) -> Result<Message, NetError> {
    tokio::time::timeout(within, recv(c, peer)).await.map_err(|_| NetError::Timeout(format!("no {what} from {peer} within {within:?}")))?
}

/// Estimates the peer's clock offset from `samples` ping-pong exchanges (see [`crate::clock`]);
/// the peer must answer each [`Ping`](crate::messages::Ping) before anything else.
pub async fn probe_clock(c: &mut Conn, samples: usize, within: Duration) -> Result<crate::clock::Offset, NetError> {
    use crate::clock::{Sample, estimate, now_us};
    use crate::messages::Ping;
    let peer = c.get_ref().peer();
    let mut got = Vec::with_capacity(samples);
    for _ in 0..samples {
        let t0 = now_us();
        send(c, &Message::Ping(Ping { sent_us: t0 })).await?;
        let reply = tokio::time::timeout(within, recv(c, &peer))
            .await
            .map_err(|_| NetError::Timeout(format!("no answer to a clock probe from {peer} within {within:?}")))??;
        match reply {
            Message::Pong(p) if p.ping_sent_us == t0 => got.push(Sample { t0, t1: p.received_us, t2: p.sent_us, t3: now_us() }),
            m => return Err(NetError::Refused { peer, why: format!("answered a clock probe with {m:?}") }),
        }
    }
    estimate(&got).ok_or_else(|| NetError::Timeout(format!("no clock samples from {peer}")))
}

/// Connection writers still running in this process ([`flush`]).
static WRITERS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Counts a writer while it runs, also when it is aborted.
struct Writing;

impl Writing {
    fn start() -> Writing {
        WRITERS.fetch_add(1, std::sync::atomic::Ordering::AcqRel);
        Writing
    }
}

impl Drop for Writing {
    fn drop(&mut self) {
        WRITERS.fetch_sub(1, std::sync::atomic::Ordering::AcqRel);
    }
}

/// Waits, at most `within`, until every connection's writer has sent what was queued before
/// its sender was dropped and stopped: a process that said goodbye drops its senders, flushes,
/// then exits. Returns whether they all stopped in time.
pub fn flush(within: Duration) -> bool {
    let end = std::time::Instant::now() + within;
    while WRITERS.load(std::sync::atomic::Ordering::Acquire) > 0 {
        if std::time::Instant::now() >= end {
            return false;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    true
}

/// Runs a connection after its handshake until it fails, closes or falls silent for
/// [`SILENCE`]: a writer sends `out`'s messages, a heartbeat when it has had nothing to send
/// for [`HEARTBEAT`], and answers clock probes at once (ahead of queued traffic, so the frame
/// loop's pace does not enter the round trip); the reader hands every other message, with its
/// arrival time ([`now_us`]) and frame bytes, to `deliver`, and stops when that returns false.
/// Returns why the connection ended.
pub async fn run_connection(
    c: Conn,
    mut out: tokio::sync::mpsc::UnboundedReceiver<Frame>,
    mut deliver: impl FnMut(Message, u64, usize) -> bool,
) -> String {
    use crate::clock::now_us;
    use crate::limits::{HEARTBEAT, SILENCE};
    use crate::messages::Pong;
    let (mut sink, mut stream) = c.split::<Frame>();
    let (pong_tx, mut pong_rx) = tokio::sync::mpsc::unbounded_channel::<Pong>();
    // A pong and a heartbeat are a few bytes: they always encode.
    let small = |m: Message| Frame::new(&m).expect("a pong or a heartbeat fits a frame");
    let writing = Writing::start();
    let writer = tokio::spawn(async move {
        let _writing = writing;
        loop {
            let f = tokio::select! {
                biased;
                Some(p) = pong_rx.recv() => small(Message::Pong(Pong { sent_us: now_us(), ..p })),
                f = tokio::time::timeout(HEARTBEAT, out.recv()) => match f {
                    Ok(Some(f)) => f,
                    Ok(None) => break,
                    Err(_) => small(Message::Heartbeat),
                },
            };
            if sink.send(f).await.is_err() {
                break;
            }
        }
    });
    let why = loop {
        match tokio::time::timeout(SILENCE, stream.next()).await {
            Err(_) => break format!("silent for {SILENCE:?}"),
            Ok(None) => break "closed the connection".to_string(),
            Ok(Some(Err(e))) => break e.to_string(),
            Ok(Some(Ok((Message::Heartbeat, _)))) => {}
            Ok(Some(Ok((Message::Ping(p), _)))) => {
                let _ = pong_tx.send(Pong { ping_sent_us: p.sent_us, received_us: now_us(), sent_us: 0 });
            }
            Ok(Some(Ok((m, bytes)))) => {
                if !deliver(m, now_us(), bytes) {
                    break "no longer needed".to_string();
                }
            }
        }
    };
    writer.abort();
    why
}
