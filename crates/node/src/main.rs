//! `osw-node`: one switch node (occlusion switch sec. 3.2). Run two, named a and b: a listens, b
//! listens and connects to a; the display connects to both. Prints `listening on ADDR` on
//! stdout once its socket is bound (so that a launcher can use port 0).
//!
//! Exit codes: 0 after the display's goodbye, 1 on any error (message on stderr).

mod inbox;
mod link;
mod peer_queue;
mod roles;
mod switch;

use clap::Parser;
use osw_wire::config::ClusterArgs;
use osw_wire::messages::{Hello, Role};
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Parser)]
#[command(name = "osw-node", version, about = "an occlusion-switch node: OR and HC in turn")]
struct Args {
    /// a (HC on even frames) or b (HC on odd frames).
    #[arg(long)]
    name: String,
    #[command(flatten)]
    cluster: ClusterArgs,
    /// Address to listen on [default: the config's, else 127.0.0.1:0, any free port].
    #[arg(long)]
    listen: Option<String>,
    /// The peer node's address: node b connects to node a [default: node a's address in the
    /// config, for node b].
    #[arg(long)]
    peer: Option<String>,
    /// Send the whole visible set every frame (a keyframe) instead of deltas.
    #[arg(long)]
    full: bool,
    #[command(flatten)]
    agreed: osw_render::settings::AgreedArgs,
    /// Longest wait for the peer or the display, seconds (a first frame at full detail of a
    /// huge scene may need more than the default).
    #[arg(long, default_value_t = osw_wire::limits::FRAME_WAIT.as_secs_f64(), value_name = "SECS")]
    frame_timeout: f64,
    /// Largest coding of a keyframe part's ids, bytes [default: what fits a frame]: smaller
    /// to test keyframes in parts.
    #[arg(long, hide = true, default_value_t = osw_wire::limits::KEYFRAME_PART_BYTES, value_name = "BYTES")]
    keyframe_part_bytes: usize,
    /// Time OR's draws on the GPU with timestamps (`or_gpu_ms` in the statistics).
    #[arg(long)]
    gpu_times: bool,
    /// Write this node's per-frame statistics (CSV) here.
    #[arg(long)]
    stats: Option<PathBuf>,
}

fn main() -> std::process::ExitCode {
    osw_gpu::device::quiet_device_select();
    osw_render::log::init();
    let a = Args::parse();
    match run(&a) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("osw-node {}: error: {e:#}", a.name);
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(a: &Args) -> anyhow::Result<()> {
    let index = match a.name.as_str() {
        "a" => 0,
        "b" => 1,
        n => anyhow::bail!("--name {n:?}: expected a or b"),
    };
    let set = a.cluster.resolve()?;
    let cfg = &set.config;
    let listen = match (&a.listen, &a.cluster.config) {
        (Some(l), _) => l.clone(),
        (None, Some(_)) => cfg.node(&a.name)?.listen.clone(),
        (None, None) => "127.0.0.1:0".into(),
    };
    let peer = match (&a.peer, &a.cluster.config, index) {
        (Some(p), _, _) => Some(p.clone()),
        (None, Some(_), 1) => Some(cfg.node("a")?.address.clone()),
        _ => None,
    };
    let (w, h) = set.size;
    let scene = osw_scene::SceneFile::open(&set.scene)?;
    let agreed = a.agreed.resolve(cfg)?;
    let me = Hello::new(scene.content_hash(), a.name.clone(), Role::Node, agreed.said(set.size));
    let gpu = osw_gpu::Gpu::new(a.cluster.adapter.as_deref())?;
    // OR and HC draw depth and item ids: no normals are uploaded.
    let options = osw_gpu::RenderOptions { cluster_tests: agreed.cluster_tests, time_gpu: a.gpu_times, shade: false, ..Default::default() };
    let renderer = osw_gpu::Renderer::new(gpu, &scene, w, h, options)?;
    if a.gpu_times && !renderer.times_gpu() {
        anyhow::bail!("--gpu-times: adapter {} has no timestamp queries", renderer.gpu().info.name);
    }

    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build()?;
    let (events_tx, events) = std::sync::mpsc::channel();
    let listener = rt.block_on(tokio::net::TcpListener::bind(&listen)).map_err(|e| anyhow::anyhow!("cannot listen on {listen}: {e}"))?;
    let bound = listener.local_addr()?;
    if set.token.is_none() && !bound.ip().is_loopback() {
        tracing::warn!(
            "listening on {bound} without a cluster token: anyone who can reach this port can join the cluster (set --token-file)"
        );
    }
    writeln!(std::io::stdout(), "listening on {bound}")?;
    std::io::stdout().flush()?;
    let gate = Arc::new(link::CameraGate::default());
    let tls = set.tls.as_ref().map(|f| osw_wire::tls::Tls::load(&f.cert, &f.key, &f.ca)).transpose()?;
    let me = link::Me { hello: me, token: set.token.clone().map(Arc::new), tls, serving: Arc::default() };
    rt.spawn(link::accept(listener, me.clone(), events_tx.clone(), Arc::clone(&gate)));
    if let Some(peer) = &peer {
        rt.spawn(link::keep_connected(peer.clone(), me.clone(), events_tx, Arc::clone(&gate)));
    }
    let mut io = inbox::Inbox::new(index, events, gate);
    io.wait =
        std::time::Duration::try_from_secs_f64(a.frame_timeout).map_err(|e| anyhow::anyhow!("--frame-timeout {}: {e}", a.frame_timeout))?;
    let mut sw = switch::Switch::new(set.batch, a.full, scene, renderer, io);
    sw.adaptive = agreed.adaptive;
    sw.keyframe_part_bytes = a.keyframe_part_bytes.clamp(5, osw_wire::limits::KEYFRAME_PART_BYTES);
    sw.payoff = (!agreed.always_cull).then(|| osw_cull::payoff::Payoff::new(osw_cull::payoff::CullCost::at(w as u64 * h as u64)));
    // Each frame's row goes to --stats as it is made: a node may run for hours.
    let mut rows = a.stats.as_deref().map(osw_render::results::csv::Rows::create).transpose()?;
    let mut log = |f: &osw_render::results::NodeFrame| -> anyhow::Result<()> { Ok(rows.as_mut().map_or(Ok(()), |w| w.push(f))?) };
    let ran = match sw.start() {
        Ok(Some(first)) => {
            me.serving.store(true, std::sync::atomic::Ordering::Release);
            sw.run(first, &mut log)
        }
        Ok(None) => Ok(()),
        Err(e) => Err(e),
    };
    sw.goodbye(if ran.is_ok() { "done" } else { "error" });
    let (roles, dropped) = (&sw.io.roles, sw.io.cameras_dropped());
    if roles.peer_losses + roles.peer_rejoins > 0 || dropped > 0 {
        tracing::warn!("{} peer losses, {} rejoins, {dropped} cameras dropped", roles.peer_losses, roles.peer_rejoins);
    }
    // The goodbye goes out before the process does: the links' senders dropped, their writers
    // send what is queued and stop.
    drop(sw);
    osw_wire::net::flush(std::time::Duration::from_secs(1));
    rt.shutdown_timeout(std::time::Duration::from_millis(200));
    ran?;
    Ok(rows.map_or(Ok(()), |w| w.finish())?)
}
