//! The interactive walkthrough under Xvfb with scripted input (xdotool). A person's
//! walk: move forward, start recording, turn and step sideways, stop recording, colour by
//! state, take a screenshot, quit. Checked: the keys moved the camera and a mouse drag turned
//! it, the screenshot and the window itself (grabbed from the X server with xwd) are not
//! blank, and the recorded path replayed headless by `osw run`, and in the window by
//! `osw play`, gives the walk's frames pixel for pixel.
//!
//! Needs Xvfb, xdotool and xwd (scripts/setup.sh installs them); skipped with a message when
//! they are missing, except under CI, where that is a failure.

mod common;
use common::*;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const SIZE: &str = "320x240";

fn have(tool: &str) -> bool {
    Command::new("sh").args(["-c", &format!("command -v {tool}")]).output().is_ok_and(|o| o.status.success())
}

/// An X server of its own: Xvfb picks a free display number and writes it to stdout.
fn xvfb() -> (Proc, String) {
    let mut x = Command::new("Xvfb")
        .args(["-displayfd", "1", "-screen", "0", "640x480x24", "-nolisten", "tcp"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start Xvfb");
    let mut line = String::new();
    BufReader::new(x.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let display = format!(":{}", line.trim());
    assert!(line.trim().parse::<u32>().is_ok(), "Xvfb gave no display number: {line:?}");
    (Proc(x), display)
}

/// Runs an X client on `display`; returns its stdout.
fn x(display: &str, tool: &str, args: &[&str]) -> Vec<u8> {
    let out = Command::new(tool).args(args).env("DISPLAY", display).output().unwrap_or_else(|e| panic!("{tool}: {e}"));
    assert!(out.status.success(), "{tool} {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out.stdout
}

/// Distinct colours in an XWD dump: the pixels are its last bytes_per_line x height bytes.
fn xwd_colours(dump: &[u8]) -> usize {
    let field = |k: usize| u32::from_be_bytes(dump[4 * k..4 * k + 4].try_into().unwrap()) as usize;
    let (height, bytes_per_line, bits) = (field(5), field(12), field(11));
    assert_eq!(bits, 32, "xwd: expected 32-bit pixels");
    let pixels = &dump[dump.len() - bytes_per_line * height..];
    let mut seen: Vec<&[u8]> = pixels.chunks_exact(4).collect();
    seen.sort_unstable();
    seen.dedup();
    seen.len()
}

fn png_colours(path: &Path) -> usize {
    let (_, _, px) = osw_render::output::read_png(path).unwrap();
    let mut seen: Vec<&[u8]> = px.chunks_exact(4).collect();
    seen.sort_unstable();
    seen.dedup();
    seen.len()
}

#[test]
fn a_walk_records_a_path_that_replays_to_the_same_frames() {
    if !["Xvfb", "xdotool", "xwd"].iter().all(|t| have(t)) {
        assert!(std::env::var_os("CI").is_none(), "CI must have Xvfb, xdotool and xwd: scripts/setup.sh installs them");
        eprintln!("skipped: needs Xvfb, xdotool and xwd (apt-get install -y xvfb xdotool x11-apps)");
        return;
    }
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 150_000, 7);
    let start = camera_path(&scene, "walk", 2);
    let (_xvfb, display) = xvfb();
    let live = d.path().join("live");
    let mut run = Proc(
        Command::new(env!("CARGO_BIN_EXE_osw"))
            .args(["run", "--interactive", "--scene", s(&scene), "--path", s(&start), "--tau", "1", "--size", SIZE, "--out", s(&live)])
            .env("DISPLAY", &display)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("osw run --interactive"),
    );
    // What osw says (recordings, screenshots) as it says it.
    let (said_tx, said) = mpsc::channel::<String>();
    let stdout = run.0.stdout.take().unwrap();
    std::thread::spawn(move || BufReader::new(stdout).lines().map_while(Result::ok).for_each(|l| drop(said_tx.send(l))));
    let expect = |prefix: &str| -> String {
        let line = said.recv_timeout(Duration::from_secs(30)).unwrap_or_else(|_| panic!("osw never said {prefix:?}"));
        assert!(line.starts_with(prefix), "expected {prefix:?}, got {line:?}");
        line
    };
    let start_time = Instant::now();
    let window = loop {
        let out = Command::new("xdotool").args(["search", "--name", "osw walkthrough"]).env("DISPLAY", &display).output().unwrap();
        if out.status.success() {
            break String::from_utf8(out.stdout).unwrap().trim().to_string();
        }
        // The run failing (a display that cannot open, a loaded host's X server gone) says why.
        if let Some(status) = run.0.try_wait().unwrap() {
            let mut err = String::new();
            let _ = std::io::Read::read_to_string(&mut run.0.stderr.take().unwrap(), &mut err);
            panic!("osw run --interactive exited ({status}) before its window showed: {err}");
        }
        assert!(start_time.elapsed() < Duration::from_secs(120), "no window after 120 s");
        std::thread::sleep(Duration::from_millis(200));
    };
    x(&display, "xdotool", &["windowfocus", "--sync", &window]);
    x(&display, "xdotool", &["mousemove", "--window", &window, "160", "120"]);
    let hold = |key: &str, ms: u64| {
        x(&display, "xdotool", &["keydown", key]);
        std::thread::sleep(Duration::from_millis(ms));
        x(&display, "xdotool", &["keyup", key]);
    };
    hold("w", 800);
    x(&display, "xdotool", &["key", "r"]);
    hold("Left", 600);
    hold("d", 600);
    std::thread::sleep(Duration::from_millis(300));
    x(&display, "xdotool", &["key", "r"]);
    let recorded = expect("osw: recorded ");
    // Mouse look: a drag with the left button, recorded on its own.
    x(&display, "xdotool", &["key", "r"]);
    for _ in 0..8 {
        x(&display, "xdotool", &["mousedown", "1", "mousemove_relative", "--", "-10", "4", "mouseup", "1"]);
        std::thread::sleep(Duration::from_millis(60));
    }
    std::thread::sleep(Duration::from_millis(300));
    x(&display, "xdotool", &["key", "r"]);
    let dragged = expect("osw: recorded ");
    x(&display, "xdotool", &["key", "Tab", "p"]);
    let shot = expect("osw: screenshot ");
    let window_colours = xwd_colours(&x(&display, "xwd", &["-id", &window, "-silent"]));
    x(&display, "xdotool", &["key", "Escape"]);
    let status = run.0.wait().unwrap();
    let mut err = String::new();
    run.0.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(status.success(), "osw run --interactive: {status}: {err}");

    // "osw: recorded DIR/paths/recorded-000.csv frames A..=B"
    let words: Vec<&str> = recorded.split_whitespace().collect();
    let (path, span) = (Path::new(words[2]), words[4]);
    let (a, b) = span.split_once("..=").unwrap();
    let (a, b): (u64, u64) = (a.parse().unwrap(), b.parse().unwrap());
    let cams = osw_scene::path::read(path).unwrap();
    assert_eq!(cams.len() as u64, b - a + 1, "{recorded}");
    assert!(cams.len() >= 5, "a recording of over a second holds frames: {}", cams.len());
    let first = &cams[0];
    let (moved, turned) = cams
        .iter()
        .fold((0f64, 0f64), |(m, t), c| (m.max((c.position - first.position).length()), t.max(c.forward().angle_between(first.forward()))));
    assert!(moved > 0.0 && turned > 0.1, "the keys moved ({moved}) and turned ({turned} rad) the camera");
    let walk_start = osw_scene::path::read(&start).unwrap()[0].position;
    assert!((first.position - walk_start).length() > 0.0, "W moved the camera before the recording");

    let looks = osw_scene::path::read(Path::new(dragged.split_whitespace().nth(2).unwrap())).unwrap();
    let (f0, f1) = (looks[0].forward(), looks[looks.len() - 1].forward());
    assert!(f0.angle_between(f1) > 0.05 && f1.y < f0.y, "a drag left and down turned the view: {f0} -> {f1}");
    assert_eq!(looks[0].position, looks[looks.len() - 1].position, "a drag does not move the camera");

    let shot = Path::new(shot.trim_start_matches("osw: screenshot "));
    assert!(png_colours(shot) > 50, "screenshot {} is (nearly) blank", shot.display());
    assert!(window_colours > 50, "the window shows {window_colours} colours: blank");

    // The recorded path, replayed headless, gives the walk's frames.
    let replay = d.path().join("replay");
    osw_ok(&["run", "--scene", s(&scene), "--path", s(path), "--tau", "1", "--size", SIZE, "--out", s(&replay)]);
    for k in 0..cams.len() as u64 {
        let frame = |dir: &Path, i: u64| osw_render::output::read_png(&osw_render::output::frame_path(dir, i)).unwrap();
        assert!(frame(&replay, k) == frame(&live, a + k), "replayed frame {k} differs from the walk's frame {}", a + k);
    }
    // `osw play` shows the same path in the window, to its end, with the same frames.
    let played = d.path().join("played");
    let out = Command::new(env!("CARGO_BIN_EXE_osw"))
        .args(["play", "--scene", s(&scene), "--path", s(path), "--tau", "1", "--size", SIZE, "--out", s(&played)])
        .env("DISPLAY", &display)
        .output()
        .unwrap();
    assert!(out.status.success(), "osw play: {}", String::from_utf8_lossy(&out.stderr));
    for k in 0..cams.len() as u64 {
        let frame = |dir: &Path| osw_render::output::read_png(&osw_render::output::frame_path(dir, k)).unwrap();
        assert!(frame(&played) == frame(&replay), "played frame {k} differs from the headless replay");
    }
}
