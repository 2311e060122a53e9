//! `osw run`: the occlusion switch on this host: starts node a, node b and the display as
//! three processes (the `osw-node` and `osw-display` binaries beside this one), waits for the
//! display to finish the path, collects the statistics into DIR, and shuts everything down.
//! When a process fails, the others are stopped and the error names it and its last words.
//! `osw play` is `osw run --window`: a path replayed in the window.
//!
//! Three processes on one host share its cores: unless `LP_NUM_THREADS` is set, the nodes run
//! Mesa lavapipe without raster threads (`LP_NUM_THREADS=0`; ignored by other drivers) and
//! the display with lavapipe's default (a raster thread a core). Raster threads in every
//! process would compete for the cores the other two need, but RVG draws the whole visible set
//! with colour, the frame's largest pass, and alone in one thread it set the pace; a single
//! process keeps lavapipe's default too (docs/measurements/2026-12-07-constants.md, "Raster
//! threads").

use anyhow::{Context, bail};
use osw_render::Mode;
use osw_render::results::{self, Details, Duty, NodeFrame, Summary, duty_median_ms};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[derive(clap::Args)]
pub struct Args {
    /// Scene file.
    #[arg(long)]
    scene: PathBuf,
    /// Camera path CSV; with --interactive, where the walk starts [default there: outside
    /// the scene, looking at it].
    #[arg(long, required_unless_present = "interactive")]
    path: Option<PathBuf>,
    /// Show the frames in a window as they are displayed (X11; without a screen, under Xvfb).
    #[arg(long)]
    window: bool,
    /// Walk through the scene in a window instead of playing a path (keys: see
    /// `osw-display --help` and the window's overlay); ends with Esc or closing the window.
    #[arg(long)]
    interactive: bool,
    /// Pixels of error allowed by LOD selection.
    #[arg(long, default_value_t = 0.0)]
    tau: f64,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = crate::walk_args::parse_size)]
    size: (u32, u32),
    /// Do not write frame PNGs.
    #[arg(long)]
    no_frames: bool,
    /// The display draws textured surfaces in each texture's mean colour instead of sampling
    /// it (the nodes never read textures).
    #[arg(long)]
    no_textures: bool,
    /// Time OR's and RVG's draws on the GPU with timestamps (`or_gpu_ms` in the node CSVs,
    /// `rvg_gpu_ms` in stats.csv, their medians in summary.json): a read-back a draw.
    #[arg(long)]
    gpu_times: bool,
    /// Send the whole visible set every frame instead of deltas (the bandwidth comparison).
    #[arg(long)]
    full: bool,
    #[command(flatten)]
    agreed: osw_render::settings::AgreedArgs,
    /// Longest wait for one frame, seconds: the display gives up after it (a first frame at
    /// full detail of a billion triangles needs more than the default).
    #[arg(long, value_name = "SECS")]
    frame_timeout: Option<f64>,
    /// Mutual TLS on every link, with the certificates `osw certs --out DIR` made: ca.pem and
    /// node-a, node-b and display (.pem and .key).
    #[arg(long, value_name = "DIR")]
    tls: Option<PathBuf>,
    /// Output directory: frames/, stats.csv, pvs.txt, summary.json (the display's), node-a.csv
    /// and node-b.csv (each node's frames), and each process's log.
    #[arg(long)]
    out: PathBuf,
}

/// A child process with a name for messages; killed when dropped.
struct Proc {
    name: &'static str,
    child: Child,
    stderr: PathBuf,
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Proc {
    fn last_words(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default().lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("").to_owned()
    }
}

fn sibling(name: &str) -> anyhow::Result<PathBuf> {
    let exe = std::env::current_exe()?;
    let p = exe.with_file_name(name);
    if !p.exists() {
        bail!("{} not found beside {} (build it: cargo build --release)", p.display(), exe.display());
    }
    Ok(p)
}

fn spawn(name: &'static str, bin: &Path, args: &[String], out: &Path) -> anyhow::Result<Proc> {
    let stderr = out.join(format!("{}.log", name.replace(' ', "-")));
    let mut cmd = Command::new(bin);
    if name != "display" && std::env::var_os("LP_NUM_THREADS").is_none() {
        cmd.env("LP_NUM_THREADS", "0");
    }
    let child = cmd
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(&stderr)?)
        .spawn()
        .with_context(|| format!("starting {name} ({})", bin.display()))?;
    Ok(Proc { name, child, stderr })
}

/// Reads the node's `listening on ADDR` line.
fn address(p: &mut Proc) -> anyhow::Result<String> {
    let out = p.child.stdout.take().context("node stdout")?;
    let mut line = String::new();
    BufReader::new(out).read_line(&mut line)?;
    match line.trim().strip_prefix("listening on ") {
        Some(a) => Ok(a.to_owned()),
        None => bail!("node {} did not start: {}", p.name, p.last_words()),
    }
}

/// `osw play`: replays a path (e.g. one recorded in a walk) in the window.
pub fn play(a: Args) -> anyhow::Result<()> {
    if a.path.is_none() {
        bail!("osw play needs --path: the camera path to replay");
    }
    run(Args { window: true, ..a })
}

pub fn run(a: Args) -> anyhow::Result<()> {
    std::fs::create_dir_all(&a.out)?;
    let config = write_config(&a)?;
    let mut procs = start(&a, &config)?;
    // A walk has no length: no bar, only what the display says (recordings, screenshots).
    let bar = match &a.path {
        Some(p) if !a.interactive => crate::progress::frames(osw_scene::path::read(p)?.len() as u64, Mode::Switch.name()),
        _ => indicatif::ProgressBar::hidden(),
    };
    let ticker = tick(procs[0].child.stdout.take().context("display stdout")?, bar.clone());
    let node_failures = wait(&mut procs, &bar)?;
    let _ = ticker.join();
    bar.finish_and_clear();
    let summary = summarize(&a.out)?;
    let sw = summary.switch().with_context(|| format!("{}: not a switch run ({})", a.out.display(), summary.mode))?;
    if !node_failures.is_empty() {
        bail!(
            "{}; the display got all {} frames, {} of them from one node alone → {}",
            node_failures.join("; "),
            summary.frames,
            sw.degraded_frames,
            a.out.display()
        );
    }
    out!(
        "run: switch over {} frames: frame {:.1} ms median, {:.0} bytes and {:.1} ids a frame ({:.1}% saved against full), latency {:.1} ms median ({:.2} frames, p95 {:.2}; floor {:.2}) → {}",
        summary.frames,
        summary.frame_ms_median,
        sw.bytes_per_frame_mean,
        sw.ids_sent_mean,
        sw.incremental_saved_fraction * 100.0,
        sw.latency_ms_median,
        sw.latency_frames_median,
        sw.latency_frames_p95,
        sw.latency_floor_frames,
        a.out.display()
    );
    Ok(())
}

/// The settings the three processes share, written as the cluster configuration they read
/// (`DIR/cluster.toml`); what differs between them (names, addresses, outputs) goes as flags.
fn write_config(a: &Args) -> anyhow::Result<PathBuf> {
    let agreed = a.agreed.resolve(&osw_wire::config::Config::default())?;
    let config = a.out.join("cluster.toml");
    let shared = osw_wire::config::Config {
        scene: Some(a.scene.clone()),
        tau: Some(a.tau),
        size: Some(format!("{}x{}", a.size.0, a.size.1)),
        ..Default::default()
    };
    std::fs::write(&config, agreed.into_config(shared).to_toml()).with_context(|| format!("writing {}", config.display()))?;
    Ok(config)
}

/// Starts node a, node b (its peer) and the display (of both): `[display, node a, node b]`.
fn start(a: &Args, config: &Path) -> anyhow::Result<[Proc; 3]> {
    let (node, display) = (sibling("osw-node")?, sibling("osw-display")?);
    let s = |p: &Path| p.display().to_string();
    // Each process's certificate and key, named as `osw certs` names them, and the CA's.
    let tls = |who: &str| -> Vec<String> {
        a.tls.as_ref().map_or(Vec::new(), |d| {
            let f = |n: String| s(&d.join(n));
            vec![
                "--tls-cert".into(),
                f(format!("{who}.pem")),
                "--tls-key".into(),
                f(format!("{who}.key")),
                "--tls-ca".into(),
                f("ca.pem".into()),
            ]
        })
    };
    let common = |name: &str| {
        let mut v: Vec<String> = vec!["--config".into(), s(config), "--name".into(), name.into(), "--listen".into(), "127.0.0.1:0".into()];
        v.extend(tls(&format!("node-{name}")));
        for (on, flag) in [(a.full, "--full"), (a.gpu_times, "--gpu-times")] {
            if on {
                v.push(flag.into());
            }
        }
        if let Some(t) = a.frame_timeout {
            v.extend(["--frame-timeout".into(), t.to_string()]);
        }
        v
    };
    let mut args_a = common("a");
    args_a.extend(["--stats".into(), s(&a.out.join("node-a.csv"))]);
    let mut pa = spawn("node a", &node, &args_a, &a.out)?;
    let addr_a = address(&mut pa)?;
    let mut args_b = common("b");
    args_b.extend(["--peer".into(), addr_a.clone(), "--stats".into(), s(&a.out.join("node-b.csv"))]);
    let mut pb = spawn("node b", &node, &args_b, &a.out)?;
    let addr_b = address(&mut pb)?;
    let mut args_d = vec!["--config".into(), s(config), "--nodes".into(), format!("{addr_a},{addr_b}"), "--out".into(), s(&a.out)];
    args_d.extend(tls("display"));
    if let Some(p) = &a.path {
        args_d.extend(["--path".into(), s(p)]);
    }
    if let Some(t) = a.frame_timeout {
        args_d.extend(["--frame-timeout".into(), t.to_string()]);
    }
    let flags = [
        (a.no_frames, "--no-frames"),
        (a.window, "--window"),
        (a.interactive, "--interactive"),
        (a.gpu_times, "--gpu-times"),
        (a.no_textures, "--no-textures"),
    ];
    for (on, flag) in flags {
        if on {
            args_d.push(flag.into());
        }
    }
    let pd = spawn("display", &display, &args_d, &a.out)?;
    Ok([pd, pa, pb])
}

/// Follows the display's stdout: a tick of `bar` per frame displayed, its other lines shown
/// above the bar.
fn tick(display_out: std::process::ChildStdout, bar: indicatif::ProgressBar) -> std::thread::JoinHandle<()> {
    // Without a terminal (a log, a test) the bar is hidden: say every tenth of the path instead.
    let tenth = bar.length().filter(|_| bar.is_hidden()).map(|n| n.div_ceil(10).max(1));
    std::thread::spawn(move || {
        for line in BufReader::new(display_out).lines().map_while(Result::ok) {
            match line.starts_with("frame ") {
                true => {
                    bar.inc(1);
                    if tenth.is_some_and(|step| bar.position().is_multiple_of(step)) {
                        out!("run: {}/{} frames displayed", bar.position(), bar.length().unwrap_or(0));
                    }
                }
                // On stdout, as the display says it, above the bar.
                false => bar.suspend(|| out!("osw: {line}")),
            }
        }
    })
}

/// Waits for all three processes (`[display, node a, node b]`). The display failing stops the
/// run; a node failing does not (the other runs both roles: failover), and is returned to be
/// reported once the display is done.
fn wait(procs: &mut [Proc; 3], bar: &indicatif::ProgressBar) -> anyhow::Result<Vec<String>> {
    let mut done = [false; 3];
    let mut node_failures = Vec::new();
    let mut display_done: Option<Instant> = None;
    while !done.iter().all(|d| *d) {
        for (k, p) in procs.iter_mut().enumerate() {
            if done[k] {
                continue;
            }
            if let Some(status) = p.child.try_wait()? {
                done[k] = true;
                if !status.success() {
                    if k == 0 {
                        bail!("{} failed ({status}): {}", p.name, p.last_words());
                    }
                    bar.println(format!("osw: {} failed ({status}): {}; the other node goes on alone", p.name, p.last_words()));
                    node_failures.push(format!("{} failed ({status}): {}", p.name, p.last_words()));
                }
                if k == 0 {
                    display_done = Some(Instant::now());
                }
            }
        }
        // Once the display is done the nodes follow within seconds, or something hangs.
        if display_done.is_some_and(|g| g.elapsed() > Duration::from_secs(10)) {
            let stuck: Vec<&str> = procs.iter().zip(done).filter(|(_, d)| !d).map(|(p, _)| p.name).collect();
            bail!("{} did not finish within 10 s of the display", stuck.join(" and "));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(node_failures)
}

/// The display's summary with each role's stage times from the nodes' own statistics (a
/// killed node wrote none), written back to `out`.
fn summarize(out: &Path) -> anyhow::Result<Summary> {
    let mut summary = Summary::read(out)?;
    let displayed = summary.frames.max(1) as f64;
    if let Details::Switch(sw) = &mut summary.of {
        let mut or_gpu = Vec::new();
        for (file, hc, or) in [
            ("node-a.csv", &mut sw.node_a_hc_ms_median, &mut sw.node_a_or_ms_median),
            ("node-b.csv", &mut sw.node_b_hc_ms_median, &mut sw.node_b_or_ms_median),
        ] {
            let path = out.join(file);
            if path.exists() {
                let frames: Vec<NodeFrame> = results::csv::read(&path)?;
                (*hc, *or) = (duty_median_ms(&frames, Duty::Hc), duty_median_ms(&frames, Duty::Or));
                or_gpu.extend(frames.iter().filter(|f| f.duty == Duty::Or).map(|f| f.or_gpu_ms));
                sw.auth_refusals += frames.last().map_or(0, |f| f.auth_refusals);
                sw.wire_bytes_per_frame_mean += frames.last().map_or(0, |f| f.wire_bytes_sent) as f64 / displayed;
            }
        }
        sw.or_gpu_ms_median = osw_render::stats::gpu_median(or_gpu.into_iter());
    }
    summary.write(out)?;
    Ok(summary)
}
