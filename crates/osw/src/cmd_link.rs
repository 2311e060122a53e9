//! `osw link`: an impaired network link in user space, a TCP relay that delays what it carries
//! and loses packets the way TCP shows loss to an application. For machines whose kernel has
//! no netem (`tc qdisc ... netem`: "unknown qdisc"), and for runs without root: put one relay
//! in front of each node and point the peer and the display at it.
//!
//! TCP hides a lost segment behind a retransmission: the bytes arrive, late, and everything
//! sent after them waits too (head-of-line blocking). So each ~MSS-sized segment read is due
//! `delay` after it arrived, a lost one another retransmission timeout (Linux's minimum, 200
//! ms) later, and no segment overtakes the one before it. Seeded, so a run can be repeated.
//!
//! A connection to the relay opens one to `--to`; when either side closes or fails, both do,
//! so a node that dies behind the relay is seen to die. The relay runs until killed.

use anyhow::{Context, bail};
use rand::{RngExt, SeedableRng};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Address to accept connections on.
    #[arg(long)]
    listen: String,
    /// Address each connection is relayed to.
    #[arg(long)]
    to: String,
    /// One-way delay added in each direction, milliseconds.
    #[arg(long, default_value_t = 0.0)]
    delay_ms: f64,
    /// Fraction of segments lost in each direction (0.01 = 1%), each seen as a retransmission
    /// 200 ms later.
    #[arg(long, default_value_t = 0.0)]
    loss: f64,
    /// Seed of the loss draws: the same seed loses the same segments of the same traffic.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Segment size for loss: Ethernet's MSS.
const SEGMENT: usize = 1448;
/// Linux's minimum retransmission timeout: what a lost segment costs.
const RTO: Duration = Duration::from_millis(200);
/// Segments held per direction (about 6 MB).
const IN_FLIGHT: usize = 4096;

/// What one direction of a link does to the bytes on it.
#[derive(Clone, Copy)]
struct Impairment {
    delay: Duration,
    loss: f64,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if !(a.delay_ms >= 0.0 && a.delay_ms <= 60_000.0) {
        bail!("--delay-ms {}: expected 0 to 60000", a.delay_ms);
    }
    if !(0.0..1.0).contains(&a.loss) {
        bail!("--loss {}: expected a fraction in [0, 1)", a.loss);
    }
    let imp = Impairment { delay: Duration::from_secs_f64(a.delay_ms / 1e3), loss: a.loss };
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    rt.block_on(async {
        let listener = TcpListener::bind(&a.listen).await.with_context(|| format!("--listen {}", a.listen))?;
        // The port actually bound (for `--listen 127.0.0.1:0`), for whoever started the relay.
        out!("listening {}", listener.local_addr()?);
        for n in 0u64.. {
            let (down, from) = match listener.accept().await {
                Ok(c) => c,
                // Out of file descriptors, say: the connections already relayed go on.
                Err(e) => {
                    tracing::warn!("accept: {e}");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                    continue;
                }
            };
            let (to, seed) = (a.to.clone(), a.seed.wrapping_add(n.wrapping_mul(0x9E37_79B9_7F4A_7C15)));
            tokio::spawn(async move {
                let up = match TcpStream::connect(&to).await {
                    Ok(up) => up,
                    // Nothing behind the relay: the client sees the connection close, as it
                    // would see a refused one, and tries again.
                    Err(e) => return tracing::info!("{from} → {to}: {e}"),
                };
                let (_, _) = (down.set_nodelay(true), up.set_nodelay(true));
                let ((dr, dw), (ur, uw)) = (down.into_split(), up.into_split());
                let rng = |s: u64| rand_pcg::Pcg64Mcg::seed_from_u64(s);
                // Either direction ending ends both: dropping the halves closes the sockets.
                tokio::select! {
                    _ = relay(dr, uw, imp, rng(seed)) => {}
                    _ = relay(ur, dw, imp, rng(!seed)) => {}
                }
            });
        }
        Ok(())
    })
}

/// Carries one direction until its reader ends or its writer fails.
async fn relay(
    mut from: tokio::net::tcp::OwnedReadHalf,
    mut to: tokio::net::tcp::OwnedWriteHalf,
    imp: Impairment,
    mut rng: rand_pcg::Pcg64Mcg,
) {
    // Bounded, like a TCP window: a sender faster than the link waits instead of filling memory.
    let (tx, mut rx) = tokio::sync::mpsc::channel::<(Instant, Vec<u8>)>(IN_FLIGHT);
    let reader = async move {
        let mut buf = vec![0u8; 64 << 10];
        // Segments never overtake: each is due no earlier than the one before it.
        let mut last_due = Instant::now();
        while let Ok(n) = from.read(&mut buf).await {
            if n == 0 {
                break;
            }
            for seg in buf[..n].chunks(SEGMENT) {
                let lost = imp.loss > 0.0 && rng.random::<f64>() < imp.loss;
                let due = (Instant::now() + imp.delay + if lost { RTO } else { Duration::ZERO }).max(last_due);
                last_due = due;
                if tx.send((due, seg.to_vec())).await.is_err() {
                    return;
                }
            }
        }
    };
    let writer = async move {
        while let Some((due, seg)) = rx.recv().await {
            tokio::time::sleep_until(due).await;
            if to.write_all(&seg).await.is_err() {
                return;
            }
        }
    };
    // The reader ending closes the channel; the writer delivers what is due, then ends.
    let (_, ()) = tokio::join!(reader, writer);
}
