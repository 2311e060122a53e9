//! `osw-display`: the display client, RVG (paper 000 sec. 4.5). Connects to both switch nodes,
//! sends them the cameras of a path (frame k's camera is the path's row k; camera k+2 goes out
//! once frame k is in), receives from the HC node of each frame its camera, the visible-set
//! deltas and the end of frame, rebuilds V(i) = (V(i-1) - removed) ∪ added, renders it and
//! writes the frame and its statistics.
//!
//! Prints `frame N` on stdout as each frame is displayed.
//! Exit codes: 0 when every frame was rendered, 1 on any error (message on stderr).

use clap::Parser;
use futures_util::{SinkExt, StreamExt};
use osw_cull::delta::apply;
use osw_gpu::draw::Pass;
use osw_render::output::{frame_path, push_ids, write_png};
use osw_render::stats::quantile;
use osw_wire::clock::{Offset, now_us};
use osw_wire::config::{ClusterArgs, Settings};
use osw_wire::limits::PROTOCOL_VERSION;
use osw_wire::messages::{CameraPacket, Goodbye, Hello, Message, Role};
use serde::Serialize;
use std::io::Write as _;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};
use tokio::sync::mpsc::UnboundedSender;

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

/// One displayed frame.
#[derive(Clone, Copy, Debug, Default, Serialize)]
struct FrameRow {
    frame: u64,
    /// Time from the previous displayed frame to this one.
    frame_ms: f64,
    rvg_ms: f64,
    hc_ms: f64,
    latency_ms: f64,
    /// One-way latency of each link, from wall-clock stamps corrected by the estimated clock
    /// offsets: RVG → HC (this frame's camera), HC → RVG (its end of frame), HC → OR (its
    /// end of frame to the peer; filled in once the peer reports it, a frame later).
    camera_link_ms: f64,
    eof_link_ms: f64,
    peer_link_ms: f64,
    bytes: u64,
    ids_sent: u64,
    ids_full: u64,
    pvs_nodes: u32,
    triangles_drawn: u64,
    tests: u32,
}

#[derive(Serialize, Default)]
struct Summary {
    mode: String,
    tau: f64,
    frames: u64,
    frame_ms_median: f64,
    frame_ms_p95: f64,
    triangles_drawn_mean: f64,
    pvs_nodes_mean: f64,
    tests_mean: f64,
    bytes_per_frame_mean: f64,
    ids_sent_mean: f64,
    ids_full_mean: f64,
    incremental_saved_fraction: f64,
    bytes_per_id: f64,
    /// Ids per delta batch, the paper's b.
    batch: usize,
    latency_ms_median: f64,
    latency_ms_p95: f64,
    latency_ms_max: f64,
    camera_link_ms_median: f64,
    eof_link_ms_median: f64,
    peer_link_ms_median: f64,
    /// Node a's and b's clock minus the display's, and the round trip of the probe used.
    clock_offset_a_us: f64,
    clock_offset_b_us: f64,
    clock_rtt_a_us: f64,
    clock_rtt_b_us: f64,
    hc_ms_median: f64,
    rvg_ms_median: f64,
    scene: String,
    scene_hash: String,
    path: String,
    width: u32,
    height: u32,
}

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

/// A connection's reader: messages with their encoded size and arrival time, or the reason
/// the connection ended.
type Inbox = Receiver<Result<(Message, u64, u64), String>>;

/// Clock probes per node at start-up (the least round trip of them is used).
const CLOCK_PROBES: usize = 16;

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
    let mut inboxes: Vec<Inbox> = Vec::new();
    let mut outboxes: Vec<UnboundedSender<Message>> = Vec::new();
    let mut clocks = Vec::new();
    for (k, addr) in addrs.iter().enumerate() {
        let mut c = rt.block_on(osw_wire::net::connect(addr, Duration::from_secs(10)))?;
        rt.block_on(osw_wire::net::handshake(&mut c, &me, Duration::from_secs(10)))
            .map_err(|e| anyhow::anyhow!("node {}: {e}", ["a", "b"][k]))?;
        clocks.push(
            rt.block_on(osw_wire::net::probe_clock(&mut c, CLOCK_PROBES, Duration::from_secs(10)))
                .map_err(|e| anyhow::anyhow!("node {}: {e}", ["a", "b"][k]))?,
        );
        let (mut sink, mut stream) = c.split();
        let (tx, rx) = std::sync::mpsc::channel();
        rt.spawn(async move {
            loop {
                let m = match stream.next().await {
                    Some(Ok(m)) => {
                        let (at, n) = (now_us(), osw_wire::frame_len(&m) as u64);
                        Ok((m, n, at))
                    }
                    Some(Err(e)) => Err(e.to_string()),
                    None => Err("connection closed".into()),
                };
                let end = m.is_err();
                if tx.send(m).is_err() || end {
                    break;
                }
            }
        });
        let (out_tx, mut out_rx) = tokio::sync::mpsc::unbounded_channel::<Message>();
        rt.spawn(async move {
            while let Some(m) = out_rx.recv().await {
                if sink.send(m).await.is_err() {
                    break;
                }
            }
        });
        inboxes.push(rx);
        outboxes.push(out_tx);
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
    let send_both = |m: Message| outboxes.iter().for_each(|o| drop(o.send(m.clone())));
    for k in 0..cams.len().min(2) {
        send_both(packet(k));
    }
    let max_id = scene.header().node_count;
    let mut visible: Vec<u32> = Vec::new();
    let mut rows: Vec<FrameRow> = Vec::with_capacity(cams.len());
    let mut pvs_txt = String::new();
    let mut last = Instant::now();
    let mut prev_eof_sent_us = 0u64;
    for i in 0..cams.len() {
        let node = ["a", "b"][i % 2];
        let inbox = &inboxes[i % 2];
        let mut row = FrameRow { frame: i as u64, ..Default::default() };
        let next = || -> anyhow::Result<(Message, u64, u64)> {
            inbox
                .recv_timeout(WAIT)
                .map_err(|_| anyhow::anyhow!("frame {i}: nothing from node {node} for {WAIT:?}"))?
                .map_err(|e| anyhow::anyhow!("frame {i}: node {node}: {e}"))
        };
        let (m, bytes, _) = next()?;
        let cam = match m {
            Message::Camera(c) if c.frame == i as u64 => c,
            m => anyhow::bail!("frame {i}: expected the camera from node {node}, got {m:?}"),
        };
        row.bytes += bytes;
        let (mut added, mut removed) = (Vec::new(), Vec::new());
        loop {
            let (m, bytes, at) = next()?;
            row.bytes += bytes;
            match m {
                Message::Delta(d) if d.frame == i as u64 => {
                    added.extend(d.added.ids(max_id)?);
                    removed.extend(d.removed.ids(max_id)?);
                }
                Message::Keyframe(k) if k.frame == i as u64 => {
                    // The whole V(i): replaces what the deltas would have built.
                    let all = k.ids.ids(max_id)?;
                    osw_cull::delta::diff(&visible, &all, &mut added, &mut removed);
                    row.ids_sent += all.len() as u64;
                }
                Message::EndOfFrame(e) if e.frame == i as u64 => {
                    row.hc_ms = e.stats.hc_us as f64 / 1e3;
                    row.tests = e.stats.tests;
                    // Every stamp on the display's clock. The end of frame is stamped when HC
                    // queues it, behind the frame's deltas: its link time includes sending them.
                    let (hc, peer) = (clocks[i % 2], clocks[(i + 1) % 2]);
                    let ms = |later: f64, earlier: f64| (later - earlier) / 1e3;
                    row.camera_link_ms = ms(hc.to_display(e.clock.camera_received_us), cam.sampled_us as f64);
                    row.eof_link_ms = ms(at as f64, hc.to_display(e.clock.sent_us));
                    if let Some(prev) = rows.last_mut().filter(|_| e.clock.peer_eof_received_us > 0) {
                        // This node was OR in frame i-1: the peer (HC then) sent its end of
                        // frame at prev_eof_sent_us on its clock, and it arrived here.
                        prev.peer_link_ms = ms(hc.to_display(e.clock.peer_eof_received_us), peer.to_display(prev_eof_sent_us));
                    }
                    prev_eof_sent_us = e.clock.sent_us;
                    break;
                }
                m => anyhow::bail!("frame {i}: unexpected message from node {node}: {m:?}"),
            }
        }
        if row.ids_sent == 0 {
            row.ids_sent = (added.len() + removed.len()) as u64;
        }
        added.sort_unstable();
        removed.sort_unstable();
        visible = apply(&visible, &removed, &added);
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
        row.frame_ms = last.elapsed().as_secs_f64() * 1e3;
        last = Instant::now();
        push_ids(&mut pvs_txt, &visible);
        rows.push(row);
        // One line per displayed frame on stdout: `osw run` shows progress from it.
        // A closed stdout only means nobody is watching: not an error.
        let _ = writeln!(std::io::stdout(), "frame {i}");
        if i + 2 < cams.len() {
            send_both(packet(i + 2));
        }
    }
    send_both(Message::Goodbye(Goodbye { reason: "path done".into() }));
    write_outputs(a, &set, &scene, &rows, &pvs_txt, &clocks)?;
    std::thread::sleep(Duration::from_millis(50));
    rt.shutdown_timeout(Duration::from_millis(200));
    Ok(())
}

fn glam_quat(q: [f64; 4]) -> osw_scene::camera::DQuat {
    osw_scene::camera::DQuat::from_array(q).normalize()
}

fn write_outputs(
    a: &Args,
    set: &Settings,
    scene: &osw_scene::SceneFile,
    rows: &[FrameRow],
    pvs: &str,
    clocks: &[Offset],
) -> anyhow::Result<()> {
    let (w, h) = set.size;
    let col = |f: fn(&FrameRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let mean = |f: fn(&FrameRow) -> f64| col(f).iter().sum::<f64>() / rows.len().max(1) as f64;
    // The first frame waits for start-up: frame times from the second on.
    let frame_ms: Vec<f64> = rows.iter().skip(1).map(|r| r.frame_ms).collect();
    let ids_sent: f64 = rows.iter().map(|r| r.ids_sent as f64).sum();
    let ids_full: f64 = rows.iter().map(|r| r.ids_full as f64).sum();
    let bytes: f64 = rows.iter().map(|r| r.bytes as f64).sum();
    let [lo, hi] = scene.content_hash();
    let s = Summary {
        mode: "switch".into(),
        tau: set.tau,
        frames: rows.len() as u64,
        frame_ms_median: quantile(&frame_ms, 0.5),
        frame_ms_p95: quantile(&frame_ms, 0.95),
        triangles_drawn_mean: mean(|r| r.triangles_drawn as f64),
        pvs_nodes_mean: mean(|r| r.pvs_nodes as f64),
        tests_mean: mean(|r| r.tests as f64),
        bytes_per_frame_mean: mean(|r| r.bytes as f64),
        ids_sent_mean: mean(|r| r.ids_sent as f64),
        ids_full_mean: mean(|r| r.ids_full as f64),
        incremental_saved_fraction: if ids_full > 0.0 { 1.0 - ids_sent / ids_full } else { 0.0 },
        bytes_per_id: bytes / ids_sent.max(1.0),
        batch: set.batch,
        latency_ms_median: quantile(&col(|r| r.latency_ms), 0.5),
        latency_ms_p95: quantile(&col(|r| r.latency_ms), 0.95),
        latency_ms_max: quantile(&col(|r| r.latency_ms), 1.0),
        camera_link_ms_median: quantile(&col(|r| r.camera_link_ms), 0.5),
        eof_link_ms_median: quantile(&col(|r| r.eof_link_ms), 0.5),
        // The last frame's end of frame reaches no OR: it has no peer latency.
        peer_link_ms_median: quantile(&rows[..rows.len().saturating_sub(1)].iter().map(|r| r.peer_link_ms).collect::<Vec<_>>(), 0.5),
        clock_offset_a_us: clocks[0].offset_us,
        clock_offset_b_us: clocks[1].offset_us,
        clock_rtt_a_us: clocks[0].rtt_us,
        clock_rtt_b_us: clocks[1].rtt_us,
        hc_ms_median: quantile(&col(|r| r.hc_ms), 0.5),
        rvg_ms_median: quantile(&col(|r| r.rvg_ms), 0.5),
        scene: set.scene.display().to_string(),
        scene_hash: format!("{hi:016x}{lo:016x}"),
        path: a.path.display().to_string(),
        width: w,
        height: h,
    };
    std::fs::write(a.out.join("summary.json"), serde_json::to_string_pretty(&s)?)?;
    std::fs::write(a.out.join("pvs.txt"), pvs)?;
    let mut csv = String::from(
        "frame,frame_ms,rvg_ms,hc_ms,latency_ms,camera_link_ms,eof_link_ms,peer_link_ms,bytes,ids_sent,ids_full,pvs_nodes,triangles_drawn,tests\n",
    );
    for r in rows {
        csv.push_str(&format!(
            "{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{},{},{},{},{},{}\n",
            r.frame,
            r.frame_ms,
            r.rvg_ms,
            r.hc_ms,
            r.latency_ms,
            r.camera_link_ms,
            r.eof_link_ms,
            r.peer_link_ms,
            r.bytes,
            r.ids_sent,
            r.ids_full,
            r.pvs_nodes,
            r.triangles_drawn,
            r.tests
        ));
    }
    std::fs::write(a.out.join("stats.csv"), csv)?;
    Ok(())
}
