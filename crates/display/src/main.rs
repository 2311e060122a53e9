//! `osw-display`: the display client, RVG (paper 000 sec. 4.5). Connects to both switch nodes,
//! sends them the cameras of a path (frame k's camera is the path's row k; camera k+2 goes out
//! once frame k is in), receives from the HC node of each frame its camera, the visible-set
//! deltas and the end of frame, rebuilds V(i) = (V(i-1) - removed) ∪ added, renders it and
//! writes the frame and its statistics.
//!
//! Prints `frame N` on stdout as each frame is displayed.
//! Exit codes: 0 when every frame was rendered, 1 on any error (message on stderr).

mod links;
mod stats;

use clap::Parser;
use links::Cluster;
use osw_cull::delta::apply;
use osw_gpu::draw::Pass;
use osw_render::output::{frame_path, push_ids, write_png};
use osw_wire::clock::now_us;
use osw_wire::config::{ClusterArgs, Settings};
use osw_wire::limits::PROTOCOL_VERSION;
use osw_wire::messages::{CameraPacket, Goodbye, Hello, Message, Role};
use stats::{FrameRow, write_outputs};
use std::collections::VecDeque;
use std::io::Write as _;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(name = "osw-display", version, about = "the occlusion switch's display client (RVG)")]
struct Args {
    #[command(flatten)]
    cluster: ClusterArgs,
    /// Camera path CSV to play back.
    #[arg(long)]
    path: PathBuf,
    /// Addresses of node a and node b, "A,B" [default: the config's].
    #[arg(long)]
    nodes: Option<String>,
    /// Do not write frame PNGs.
    #[arg(long)]
    no_frames: bool,
    /// Output directory: frames/NNNNN.png, stats.csv, pvs.txt, summary.json.
    #[arg(long)]
    out: PathBuf,
}

/// Longest wait for the HC node's next message.
const WAIT: Duration = Duration::from_secs(30);

fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_env("OSW_LOG").unwrap_or_else(|_| "warn".into()))
        .init();
    match run(&Args::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("osw-display: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// Node a's and node b's addresses: `--nodes`, else the configuration's.
fn node_addresses(a: &Args, set: &Settings) -> anyhow::Result<[String; 2]> {
    Ok(match (&a.nodes, &a.cluster.config) {
        (Some(n), _) => match n.split(',').map(str::trim).collect::<Vec<_>>().as_slice() {
            [x, y] => [x.to_string(), y.to_string()],
            _ => anyhow::bail!("--nodes {n:?}: expected two addresses, node a's and node b's"),
        },
        (None, Some(_)) => {
            let addr = |k: &str| set.config.node(k).map(|n| n.address.clone()).map_err(anyhow::Error::msg);
            [addr("a")?, addr("b")?]
        }
        (None, None) => anyhow::bail!("no nodes: give --nodes A,B or --config"),
    })
}

fn run(a: &Args) -> anyhow::Result<()> {
    let set = a.cluster.resolve().map_err(anyhow::Error::msg)?;
    let (w, h) = set.size;
    let addrs = &node_addresses(a, &set)?;
    let cams = osw_scene::path::read(&a.path)?;
    let scene = Arc::new(osw_scene::SceneFile::open(&set.scene)?);
    let me = Hello {
        version: PROTOCOL_VERSION,
        scene_hash: scene.content_hash(),
        name: "display".into(),
        role: Role::Display,
        token: set.token.clone(),
    };
    let gpu = osw_gpu::Gpu::new(a.cluster.adapter.as_deref())?;
    let mut r = osw_gpu::Renderer::new(gpu, Arc::clone(&scene), w, h, osw_gpu::limits::RESIDENCY_BYTES)?;
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build()?;
    let (notes_tx, notes) = std::sync::mpsc::channel();
    for (k, addr) in addrs.iter().enumerate() {
        rt.spawn(links::keep_node(k, addr.clone(), me.clone(), notes_tx.clone(), Duration::from_secs(10)));
    }
    drop(notes_tx);
    let mut cluster = Cluster::default();
    while cluster.nodes.iter().any(Option::is_none) {
        let note = notes.recv_timeout(WAIT).map_err(|_| anyhow::anyhow!("the nodes did not connect within {WAIT:?}"))?;
        cluster.note(note)?;
    }
    std::fs::create_dir_all(a.out.join("frames"))?;
    let packet = |k: usize| {
        let c = &cams[k];
        Message::Camera(CameraPacket {
            frame: k as u64,
            position: c.position.to_array(),
            orientation: c.orientation.to_array(),
            fovy_deg: c.fovy_deg,
            sampled_us: now_us(),
        })
    };
    for k in 0..cams.len().min(2) {
        cluster.send_camera(packet(k));
    }
    let max_id = scene.header().node_count;
    let mut visible: Vec<u32> = Vec::new();
    let mut rows: Vec<FrameRow> = Vec::with_capacity(cams.len());
    let mut pvs_txt = String::new();
    let mut last = Instant::now();
    // The node that sent the previous frame and when it sent its end of frame.
    let mut prev_eof: Option<(usize, u64)> = None;
    // Messages not for the frame at hand yet (the next HC may start before this frame is
    // shown) or from the node that is not its source (kept in case the source is lost).
    let mut held: VecDeque<Arrival> = VecDeque::new();
    for i in 0..cams.len() {
        let mut row = FrameRow { frame: i as u64, ..Default::default() };
        // Frame i comes from the node that sends its camera first (the HC node, or the one
        // running alone); if that node is lost before its end of frame, from the other.
        let mut source: Option<(usize, CameraPacket)> = None;
        let (mut added, mut removed, mut keyframe) = (Vec::new(), Vec::new(), None);
        let mut replay: VecDeque<Arrival> = std::mem::take(&mut held);
        loop {
            let (node, m, bytes, at) = match replay.pop_front() {
                Some(x) => x,
                None => {
                    let note = notes.recv_timeout(WAIT).map_err(|_| anyhow::anyhow!("frame {i}: nothing from the nodes for {WAIT:?}"))?;
                    match cluster.note(note)? {
                        Some(x) => x,
                        None => {
                            if let Some((lost, _)) = source.filter(|(n, _)| cluster.nodes[*n].is_none()) {
                                tracing::warn!("frame {i}: node {} lost mid-frame; reading the frame from the other", links::NAMES[lost]);
                                (source, keyframe, row.bytes, row.ids_sent) = (None, None, 0, 0);
                                added.clear();
                                removed.clear();
                                replay = std::mem::take(&mut held);
                            }
                            continue;
                        }
                    }
                }
            };
            let from_source = source.is_some_and(|(n, _)| n == node);
            match m {
                Message::Camera(c) if c.frame == i as u64 && source.is_none() => {
                    source = Some((node, c));
                    row.bytes += bytes;
                }
                // Another node's, or another frame's: kept while it may still be needed (an
                // earlier frame's is a node taking over a frame this display already has).
                m if !from_source || frame_of(&m) != Some(i as u64) => {
                    if frame_of(&m).is_some_and(|f| f >= i as u64) {
                        held.push_back((node, m, bytes, at));
                    }
                }
                Message::Delta(d) if d.frame == i as u64 => {
                    let (ad, rm) = (d.added.ids(max_id)?, d.removed.ids(max_id)?);
                    (row.bytes, row.ids_sent) = (row.bytes + bytes, row.ids_sent + (ad.len() + rm.len()) as u64);
                    added.extend(ad);
                    removed.extend(rm);
                }
                Message::Keyframe(k) if k.frame == i as u64 => {
                    // The whole V(i): replaces V(i-1) and what deltas would have built.
                    row.bytes += bytes;
                    let all = k.ids.ids(max_id)?;
                    row.ids_sent += all.len() as u64;
                    keyframe = Some(all);
                }
                Message::EndOfFrame(e) if e.frame == i as u64 => {
                    row.bytes += bytes;
                    row.hc_ms = e.stats.hc_us as f64 / 1e3;
                    row.tests = e.stats.tests;
                    let (hc, cam) = source.expect("from the source");
                    // Every stamp on the display's clock. The end of frame is stamped when HC
                    // queues it, behind the frame's deltas: its link time includes sending them.
                    let clock = |n: usize| cluster.clocks[n];
                    let ms = |later: f64, earlier: f64| (later - earlier) / 1e3;
                    row.camera_link_ms = ms(clock(hc).to_display(e.clock.camera_received_us), cam.sampled_us as f64);
                    row.eof_link_ms = ms(at as f64, clock(hc).to_display(e.clock.sent_us));
                    if let (Some(prev), Some((sender, sent))) =
                        (rows.last_mut(), prev_eof.filter(|p| p.0 != hc && e.clock.peer_eof_received_us > 0))
                    {
                        // This node was OR in frame i-1: the peer (HC then) sent its end of
                        // frame then, on its clock, and it arrived here.
                        prev.peer_link_ms = ms(clock(hc).to_display(e.clock.peer_eof_received_us), clock(sender).to_display(sent));
                    }
                    prev_eof = Some((hc, e.clock.sent_us));
                    row.hc_node = hc as u32;
                    row.degraded = cluster.nodes.iter().any(Option::is_none) as u32;
                    break;
                }
                m => anyhow::bail!("frame {i}: unexpected message from node {}: {m:?}", links::NAMES[node]),
            }
        }
        let cam = source.expect("a complete frame has a camera").1;
        added.sort_unstable();
        removed.sort_unstable();
        visible = apply(keyframe.as_ref().unwrap_or(&visible), &removed, &added);
        row.ids_full = visible.len() as u64;
        let t = Instant::now();
        r.begin_frame();
        let camera = osw_scene::Camera { position: cam.position.into(), orientation: glam_quat(cam.orientation), fovy_deg: cam.fovy_deg };
        let view = r.view(&camera);
        let drawn = r.draw(&view, &visible, Pass::Color, true)?;
        row.rvg_ms = t.elapsed().as_secs_f64() * 1e3;
        (row.pvs_nodes, row.triangles_drawn) = (drawn.nodes, drawn.triangles);
        if !a.no_frames {
            write_png(&frame_path(&a.out, i as u64), w, h, r.read_color()?).map_err(anyhow::Error::msg)?;
        }
        row.latency_ms = now_us().saturating_sub(cam.sampled_us) as f64 / 1e3;
        row.rss_kb = osw_render::stats::resident_bytes() >> 10;
        row.frame_ms = last.elapsed().as_secs_f64() * 1e3;
        last = Instant::now();
        push_ids(&mut pvs_txt, &visible);
        rows.push(row);
        // One line per displayed frame on stdout: `osw run` shows progress from it.
        // A closed stdout only means nobody is watching: not an error.
        let _ = writeln!(std::io::stdout(), "frame {i}");
        if i + 2 < cams.len() {
            cluster.send_camera(packet(i + 2));
        }
    }
    cluster.send_all(Message::Goodbye(Goodbye { reason: "path done".into() }));
    write_outputs(a, &set, &scene, &rows, &pvs_txt, &cluster)?;
    std::thread::sleep(Duration::from_millis(50));
    rt.shutdown_timeout(Duration::from_millis(200));
    Ok(())
}

/// A node's message as it arrived: node, message, frame bytes, arrival time.
type Arrival = (usize, Message, u64, u64);

/// The frame a frame message belongs to.
fn frame_of(m: &Message) -> Option<u64> {
    match m {
        Message::Camera(c) => Some(c.frame),
        Message::Delta(d) => Some(d.frame),
        Message::Keyframe(k) => Some(k.frame),
        Message::EndOfFrame(e) => Some(e.frame),
        _ => None,
    }
}

fn glam_quat(q: [f64; 4]) -> osw_scene::camera::DQuat {
    osw_scene::camera::DQuat::from_array(q).normalize()
}
