//! `osw-display`: the display client, RVG (occlusion switch sec. 4.5). Connects to both switch nodes,
//! sends them cameras (frame k's camera is the path's row k, or in a walk the camera as the
//! person has moved it; camera k+2 goes out once frame k is drawn), receives from the HC node of
//! each frame its camera, the visible-set deltas and the end of frame, rebuilds
//! V(i) = (V(i-1) - removed) ∪ added, renders it, writes the frame and its statistics, and
//! with `--window` or `--interactive` shows it in a window.
//!
//! Prints `frame N` on stdout as each frame is displayed (and in a window, where recordings and
//! screenshots went).
//! Exit codes: 0 when every frame was rendered, 1 on any error (message on stderr).

mod controls;
mod links;
mod overlay;
mod receive;
mod stats;
mod ui;
mod window;
mod writer;

use clap::Parser;
use osw_cull::cluster::VisibleClusters;
use osw_gpu::RenderOptions;
use osw_render::output::push_ids;
use osw_render::results::DisplayFrame;
use osw_scene::Camera;
use osw_scene::camera::DVec3;
use osw_wire::clock::now_us;
use osw_wire::config::{ClusterArgs, Settings};
use osw_wire::messages::{Goodbye, Hello, Message, Role};
use receive::Frames;
use stats::write_outputs;
use std::io::Write as _;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use ui::Ui;
use writer::FrameWriter;

#[derive(Parser)]
#[command(name = "osw-display", version, about = "the occlusion switch's display client (RVG)")]
struct Args {
    #[command(flatten)]
    cluster: ClusterArgs,
    /// Camera path CSV to play back; with --interactive, where the walk starts (its first
    /// camera) [default there: looking at the scene from outside].
    #[arg(long, required_unless_present = "interactive")]
    path: Option<PathBuf>,
    /// Show the frames in a window (X11; without a screen, under Xvfb).
    #[arg(long)]
    window: bool,
    /// Walk through the scene in a window: WASD/QE move, drag or arrows look, Z/X speed, [ ]
    /// tau, Tab colours by state, F freezes the culling camera, R records the path, P saves a
    /// screenshot, H hides the overlay, Esc ends the walk.
    #[arg(long)]
    interactive: bool,
    /// Addresses of node a and node b, "A,B" [default: the config's].
    #[arg(long)]
    nodes: Option<String>,
    /// Do not write frame PNGs.
    #[arg(long)]
    no_frames: bool,
    /// End without the goodbye that stops the nodes: they wait for the next display, which
    /// they serve from the start of its path (a soak's laps, several paths in turn).
    #[arg(long)]
    leave_running: bool,
    /// The settings the nodes run with (the display draws with the cluster tests).
    #[command(flatten)]
    agreed: osw_render::settings::AgreedArgs,
    /// Time RVG's draw on the GPU with timestamps (`rvg_gpu_ms` in stats.csv).
    #[arg(long)]
    gpu_times: bool,
    /// Draw textured surfaces in each texture's mean colour instead of sampling it.
    #[arg(long)]
    no_textures: bool,
    /// Longest wait for one frame, seconds (a first frame at full detail of a huge scene may
    /// need more than the default).
    #[arg(long, default_value_t = osw_wire::limits::FRAME_WAIT.as_secs_f64(), value_name = "SECS")]
    frame_timeout: f64,
    /// Play the path at no more than this many frames a second, as a display refreshed at
    /// that rate shows it [default: each frame as soon as it comes].
    #[arg(long, value_name = "FPS")]
    fps: Option<f64>,
    /// Output directory: frames/NNNNN.png, stats.csv, pvs.txt, summary.json; paths/ and
    /// screenshots/ from the window.
    #[arg(long)]
    out: PathBuf,
}

fn main() -> std::process::ExitCode {
    osw_gpu::device::quiet_device_select();
    osw_render::log::init();
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
            let addr = |k: &str| set.config.node(k).map(|n| n.address.clone());
            [addr("a")?, addr("b")?]
        }
        (None, None) => anyhow::bail!("no nodes: give --nodes A,B or --config"),
    })
}

/// Where a walk starts without a path: outside the scene's box, looking at its centre.
fn overview(scene: &osw_scene::SceneFile) -> Camera {
    let b = scene.node(0).aabb();
    let (c, e) = (b.center().as_dvec3() + scene.origin(), b.extent().as_dvec3());
    Camera::look_at(c + DVec3::new(0.6 * e.x, 0.5 * e.y + 0.1 * e.length(), 0.9 * e.z), c, 60.0)
}

/// The window (with the walk's controls when interactive) and its GPU, or a GPU alone.
fn open(a: &Args, set: &Settings, scene: &Arc<osw_scene::SceneFile>, start: Option<&Camera>) -> anyhow::Result<(Option<Ui>, osw_gpu::Gpu)> {
    let (w, h) = set.size;
    if !(a.window || a.interactive) {
        return Ok((None, osw_gpu::Gpu::new(a.cluster.adapter.as_deref())?));
    }
    let (window, gpu) = window::Window::open("osw walkthrough", w, h, a.cluster.adapter.as_deref())?;
    let controls = a.interactive.then(|| {
        let start = start.copied().unwrap_or_else(|| overview(scene));
        controls::Controls::new(&start, scene.node(0).aabb().extent().length() as f64 / 20.0, set.tau)
    });
    Ok((Some(Ui::new(window, controls, h, a.out.clone(), Arc::clone(scene))), gpu))
}

/// RVG of frame `i`, which `frames` holds, from `camera`, as prev's: the clusters HC found
/// hidden are left out. Its time and counts go into `row`.
fn rvg(
    r: &mut osw_gpu::Renderer,
    scene: &osw_scene::SceneFile,
    frames: &mut Frames,
    i: usize,
    camera: &Camera,
    tau: f64,
    row: &mut DisplayFrame,
) -> anyhow::Result<()> {
    let t = Instant::now();
    r.begin_frame();
    let view = r.view(camera, tau);
    let notes = match frames.mask.take() {
        Some(m) => Some(
            VisibleClusters::from_mask(&frames.visible, |id| scene.opaque_clusters(id), m)
                .map_err(|e| anyhow::anyhow!("frame {i}: node {}: {e}", links::NAMES[row.hc_node as usize]))?,
        ),
        None => None,
    };
    let drawn = osw_render::pass::rvg(r, scene, &view, &frames.visible, notes.as_ref(), osw_gpu::draw::Pass::Color)?;
    (row.rvg_ms, row.rvg_gpu_ms) = (t.elapsed().as_secs_f64() * 1e3, drawn.gpu_ms());
    (row.pvs_nodes, row.triangles_drawn) = (drawn.nodes, drawn.triangles);
    [
        row.clusters,
        row.clusters_frustum_culled,
        row.clusters_cone_culled,
        row.clusters_occlusion_culled,
        row.triangles_backface_culled,
        row.triangles_small_culled,
    ] = osw_render::stats::cluster_columns(&drawn.clusters);
    Ok(())
}

/// What a walk plays: the run's arguments and settings, the path (empty in an interactive
/// walk) and the scene.
struct Plan<'a> {
    a: &'a Args,
    set: &'a Settings,
    path: &'a [Camera],
    scene: &'a osw_scene::SceneFile,
    /// The shortest time from one frame's camera to the next (`--fps`).
    period: Option<Duration>,
}

/// `--fps`'s period.
fn fps_period(fps: f64) -> anyhow::Result<Duration> {
    if !(fps.is_finite() && fps >= 0.01) {
        anyhow::bail!("--fps {fps}: expected a number of frames a second, 0.01 or more");
    }
    Ok(Duration::from_secs_f64(1.0 / fps))
}

/// Plays the walk: receives each frame, draws it, sends the next camera, writes or shows the
/// frame; returns the frames' rows and pvs.txt.
fn walk(p: &Plan, r: &mut osw_gpu::Renderer, ui: &mut Option<Ui>, frames: &mut Frames) -> anyhow::Result<(Vec<DisplayFrame>, String)> {
    let Plan { a, set, path, scene, period } = *p;
    // Frame k's camera and tau: the path's row k, or the walk's camera as it is now.
    let next_camera = |k: usize, ui: &mut Option<Ui>| -> Option<(Camera, f64)> {
        match ui.as_mut() {
            Some(u) if u.controls.is_some() => u.next_camera(),
            Some(u) if u.quit() => None,
            _ => Some((*path.get(k)?, set.tau)),
        }
    };
    let start = Instant::now();
    let send = |frames: &mut Frames, k: usize, (c, tau): (Camera, f64)| {
        if let Some(due) = period.map(|p| start + p.mul_f64(k as f64)) {
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
        }
        frames.cluster.send_camera(&Message::Camera(osw_render::packet::packet(k as u64, &c, tau, now_us())))
    };
    // Cameras sent so far: frames 0..requested are on their way.
    let mut requested = 0;
    while requested < 2
        && let Some(c) = next_camera(requested, ui)
    {
        send(frames, requested, c)?;
        requested += 1;
    }
    let (mut rows, mut pvs_txt) = (Vec::<DisplayFrame>::with_capacity(path.len()), String::new());
    let (mut last, mut cpu) = (Instant::now(), osw_render::stats::cpu_ms());
    let mut writer = (!a.no_frames).then(|| FrameWriter::start(&a.out, set.size.0, set.size.1));
    let mut i = 0;
    while i < requested {
        let (cam, mut row) = frames.frame(i as u64, rows.last_mut(), &mut || {
            ui.as_mut().map(Ui::pump);
        })?;
        row.display_wait_ms = now_us().saturating_sub(frames.eof_at_us) as f64 / 1e3;
        let camera = osw_render::packet::camera(&cam);
        rvg(r, scene, frames, i, &camera, cam.tau_px, &mut row)?;
        // Read back once for the PNG and the window both (unless the window draws another view);
        // without either, wait for the draw: a frame counts as shown once drawn.
        let t = Instant::now();
        let mut rgba = if !a.no_frames || ui.as_ref().is_some_and(|u| !u.redraws(&camera)) {
            Some(r.read_color()?)
        } else {
            r.gpu().wait()?;
            None
        };
        row.readback_ms = t.elapsed().as_secs_f64() * 1e3;
        // Camera i+2 goes out once frame i is drawn, as it is now (a walk's newest input),
        // before the frame is written or shown. Sent earlier (at frame i's end), the nodes run
        // ahead of RVG and frames wait for it: a third frame in flight, three frames of latency
        // instead of two (docs/switch.md, "Latency").
        if i + 2 == requested
            && let Some(c) = next_camera(i + 2, ui)
        {
            send(frames, i + 2, c)?;
            requested += 1;
        }
        // A window's frame counts once presented (it keeps at most one in its queue).
        if let Some(u) = ui.as_mut() {
            // The overlay shows the last frame's latency: this one's ends with the present.
            let shown = DisplayFrame { latency_ms: rows.last().map_or(0.0, |r| r.latency_ms), ..row };
            let frame = if writer.is_some() { rgba.clone() } else { rgba.take() };
            u.show(r, frame, &frames.visible, &camera, cam.tau_px, &shown)?;
        }
        row.latency_ms = now_us().saturating_sub(cam.sampled_us) as f64 / 1e3;
        if let (Some(wr), Some(rgba)) = (writer.as_mut(), rgba) {
            row.write_ms = wr.write(i as u64, rgba)?;
        }
        (row.rss_kb, row.anon_kb) = (osw_render::stats::resident_bytes() >> 10, osw_render::stats::anonymous_bytes() >> 10);
        row.frame_ms = last.elapsed().as_secs_f64() * 1e3;
        let now = osw_render::stats::cpu_ms();
        (row.cpu_ms, cpu) = (now - cpu, now);
        last = Instant::now();
        push_ids(&mut pvs_txt, &frames.visible);
        rows.push(row);
        // One line per displayed frame on stdout: `osw run` shows progress from it.
        // A closed stdout only means nobody is watching: not an error.
        let _ = writeln!(std::io::stdout(), "frame {i}");
        i += 1;
    }
    if let Some(wr) = writer {
        wr.finish()?;
    }
    Ok((rows, pvs_txt))
}

fn run(a: &Args) -> anyhow::Result<()> {
    let period = a.fps.map(fps_period).transpose()?;
    let set = a.cluster.resolve()?;
    let (w, h) = set.size;
    let addrs = &node_addresses(a, &set)?;
    let path = a.path.as_deref().map(osw_scene::path::read).transpose()?.unwrap_or_default();
    let scene = Arc::new(osw_scene::SceneFile::open(&set.scene)?);
    let agreed = a.agreed.resolve(&set.config)?;
    // This display's session: its path is the nodes' from its first frame (node peer_queue).
    let me = Hello { session: now_us(), ..Hello::new(scene.content_hash(), "display", Role::Display, agreed.said(set.size)) };
    let tls = set.tls.as_ref().map(|f| osw_wire::tls::Tls::load(&f.cert, &f.key, &f.ca)).transpose()?;
    let (mut ui, gpu) = open(a, &set, &scene, path.first())?;
    // The next frame's gather overlaps this frame's draw (measured in
    // docs/measurements/2026-12-07-constants.md, "The display's overlap"). RVG's stage time then
    // ends when its draw is submitted, the previous one done.
    let options = RenderOptions {
        cluster_tests: agreed.cluster_tests,
        time_gpu: a.gpu_times,
        overlap: true,
        textures: !a.no_textures,
        ..RenderOptions::default()
    };
    let mut r = osw_gpu::Renderer::new(gpu, &scene, w, h, options)?;
    if a.gpu_times && !r.times_gpu() {
        anyhow::bail!("--gpu-times: adapter {} has no timestamp queries", r.gpu().info.name);
    }
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build()?;
    let (notes_tx, notes) = std::sync::mpsc::channel();
    for (k, addr) in addrs.iter().enumerate() {
        let who = links::Me { hello: me.clone(), token: set.token.clone(), tls: tls.clone() };
        rt.spawn(links::keep_node(k, addr.clone(), who, notes_tx.clone(), Duration::from_secs(10)));
    }
    drop(notes_tx);
    let wait = Duration::try_from_secs_f64(a.frame_timeout).map_err(|e| anyhow::anyhow!("--frame-timeout {}: {e}", a.frame_timeout))?;
    let mut frames = Frames::connect(notes, scene.header().node_count, wait, &mut || {
        ui.as_mut().map(Ui::pump);
    })?;
    std::fs::create_dir_all(a.out.join("frames"))?;
    let plan = Plan { a, set: &set, path: &path, scene: &scene, period };
    let (rows, pvs_txt) = walk(&plan, &mut r, &mut ui, &mut frames)?;
    if let Some(u) = ui.as_mut() {
        u.finish();
    }
    if !a.leave_running {
        frames.cluster.send_all(osw_wire::Frame::new(&Message::Goodbye(Goodbye { reason: "walk done".into() }))?);
    }
    let written = write_outputs(a, &set, &scene, &rows, &pvs_txt, &frames.cluster, &r.residency_stats());
    // The goodbye goes out before the process does (see osw_wire::net::flush).
    drop(frames);
    osw_wire::net::flush(Duration::from_secs(1));
    rt.shutdown_timeout(Duration::from_millis(200));
    written
}
