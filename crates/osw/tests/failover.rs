//! Failover on loopback, with the processes started by hand on fixed ports as on
//! three machines: node a killed at frame 50 of a 480-frame walk and restarted at frame 120
//! rejoins, whether its peer or the display reaches it first; the display gets every frame, marks the degraded span, and every frame equals
//! frustum-only rendering with no exactly visible leaf culled. A display killed and started
//! again is served from the start of its path; one whose link to a node is cut and back goes
//! on with its path. Silent and garbage connections are refused
//! on their own while the walk goes on.

mod common;
use common::*;
use osw_render::results::{self, DisplayFrame, Duty, NodeFrame};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const SIZE: &str = "192x192";

/// Whether a TCP connection to local port `port` is established (`ss`).
fn established_to(port: &str) -> bool {
    let out = Command::new("ss").args(["-Htn", "state", "established", &format!("( sport = :{port} )")]).output().unwrap();
    !out.stdout.is_empty()
}

/// A loopback address with a port free now.
fn free_addr() -> String {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().to_string()
}

fn node(name: &str, scene: &Path, listen: &str, peer: Option<&str>, log: &Path) -> Proc {
    let mut c = Command::new(bin("osw-node"));
    c.args(["--name", name, "--scene", s(scene), "--size", SIZE, "--listen", listen]);
    c.args(["--stats", s(&log.with_extension("csv"))]);
    if let Some(p) = peer {
        c.args(["--peer", p]);
    }
    Proc(c.stdout(Stdio::null()).stderr(std::fs::File::create(log).unwrap()).spawn().unwrap())
}

fn display(scene: &Path, path: &Path, nodes: &str, out: &Path, extra: &[&str]) -> Proc {
    std::fs::create_dir_all(out).unwrap();
    let c = Command::new(bin("osw-display"))
        .args(["--scene", s(scene), "--path", s(path), "--nodes", nodes, "--size", SIZE, "--out", s(out)])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(out.with_extension("log")).unwrap())
        .spawn()
        .unwrap();
    Proc(c)
}

/// Reads the display's `frame N` lines, calling `at(N)` for each; returns when it exits.
fn follow(d: &mut Proc, mut at: impl FnMut(u64)) -> std::process::ExitStatus {
    let lines = BufReader::new(d.0.stdout.take().unwrap()).lines();
    for l in lines.map_while(Result::ok) {
        if let Some(n) = l.strip_prefix("frame ").and_then(|n| n.parse().ok()) {
            at(n);
        }
    }
    d.0.wait().unwrap()
}

/// The last lines of each of the processes' logs, for a failure's message.
fn logs(d: &Path, names: &[&str]) -> String {
    let tail = |n: &&str| {
        let text = std::fs::read_to_string(d.join(n)).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        format!("--- {n}\n{}", lines[lines.len().saturating_sub(40)..].join("\n"))
    };
    names.iter().map(tail).collect::<Vec<_>>().join("\n")
}

/// Every frame of `run` equals vfc's and culls no exactly visible leaf.
fn check_against_references(d: &Path, scene: &Path, path: &Path, run: &Path) {
    let (vfc, exact) = (d.join("vfc"), d.join("exact"));
    if !exact.exists() {
        osw_ok(&["exact", "--scene", s(scene), "--path", s(path), "--size", SIZE, "--out", s(&exact)]);
        osw_ok(&["render", "--scene", s(scene), "--path", s(path), "--mode", "vfc", "--size", SIZE, "--out", s(&vfc)]);
    }
    let c = compare(run, &vfc, &exact, &run.with_extension("cmp"));
    assert_same_frames(&c, c["frames"].as_u64().unwrap() as usize, &format!("{} against vfc", run.display()));
    assert_eq!(c["culling_a"]["false_culled_leaves_total"], 0, "{}: false culling: {c}", run.display());
}

/// Frames of the walk: enough after the restart at frame 120 for the rejoin (a new process,
/// its device, the display's held-off link) and a tail of frames in turn, also when a frame
/// takes 5 ms.
const FRAMES: u64 = 480;

fn walk(d: &Path) -> (PathBuf, PathBuf) {
    let scene = build_gen(d, "plant", 150_000, 7);
    let path = camera_path(&scene, "walk", FRAMES as u32);
    (scene, path)
}

/// An impaired link in front of `to` (`osw link`) listening on `listen`: returns the relay and
/// its address.
fn link(listen: &str, to: &str, delay_ms: &str, loss: &str, seed: &str) -> (Proc, String) {
    let mut p = Proc(
        Command::new(env!("CARGO_BIN_EXE_osw"))
            .args(["link", "--listen", listen, "--to", to, "--delay-ms", delay_ms, "--loss", loss, "--seed", seed])
            .stdout(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut line = String::new();
    BufReader::new(p.0.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let addr = line.trim().strip_prefix("listening ").unwrap_or_else(|| panic!("osw link said {line:?}")).to_string();
    (p, addr)
}

#[test]
fn a_node_killed_and_restarted_rejoins_and_no_frame_is_lost() {
    kill_and_restart(None, First::Peer);
}

/// As above, every link 5 ms long each way and losing 1% of its segments (the kernel here has
/// no netem: `osw link` relays each connection, delaying and stalling it as TCP would).
#[test]
fn the_same_over_links_with_delay_and_loss() {
    kill_and_restart(Some(("5", "0.01")), First::Peer);
}

/// As above, the display reaching the restarted node before node b does: the node waits for
/// its peer with the display's cameras piling up, then rejoins.
#[test]
fn a_restarted_node_the_display_reaches_before_its_peer_rejoins() {
    kill_and_restart(None, First::Display);
}

/// Which of the restarted node a's links comes back first.
#[derive(Clone, Copy, PartialEq)]
enum First {
    Peer,
    Display,
}

/// What the peer and the display connect to: node a for b, node a and node b for the display;
/// the nodes themselves, or `osw link` relays in front of them. The display always reaches
/// node a through a relay (returned apart, with its address), so that a test can hold that
/// link down.
fn links(addr_a: &str, addr_b: &str, impaired: Option<(&str, &str)>) -> (Vec<Proc>, (Proc, String), [String; 2]) {
    let (delay, loss) = impaired.unwrap_or(("0", "0"));
    let display_to_a = link("127.0.0.1:0", addr_a, delay, loss, "2");
    match impaired {
        None => (vec![], display_to_a, [addr_a.to_string(), addr_b.to_string()]),
        Some(_) => {
            let [(p1, x1), (p3, x3)] = [(addr_a, "1"), (addr_b, "3")].map(|(to, seed)| link("127.0.0.1:0", to, delay, loss, seed));
            (vec![p1, p3], display_to_a, [x1, x3])
        }
    }
}

fn kill_and_restart(impaired: Option<(&str, &str)>, order: First) {
    let d = tempfile::tempdir().unwrap();
    let (scene, path) = walk(d.path());
    let (addr_a, addr_b) = (free_addr(), free_addr());
    let (_links, (relay, to_a), [to_a_from_b, to_b]) = links(&addr_a, &addr_b, impaired);
    let display_to_a = std::sync::Arc::new(std::sync::Mutex::new(Some(relay)));
    // Where the display comes back first, node b reaches node a through a relay of its own,
    // held down until then.
    let between = free_addr();
    let b_to_a = std::sync::Arc::new(std::sync::Mutex::new((order == First::Display).then(|| link(&between, &addr_a, "0", "0", "5").0)));
    let peer_of_b = if order == First::Display { between.clone() } else { to_a_from_b };
    let mut a = Some(node("a", &scene, &addr_a, None, &d.path().join("a1.log")));
    let _b = node("b", &scene, &addr_b, Some(&peer_of_b), &d.path().join("b.log"));
    let out = d.path().join("run");
    // Paced: the rejoin takes a restarted process's start and two reconnections' backoff
    // (about 1.5 s here), while node b alone runs a frame in 4 ms.
    let mut disp = display(&scene, &path, &format!("{to_a},{to_b}"), &out, &["--fps", "40"]);
    let (mut killed_at, mut restarted_at, mut relay_back) = (None, None, None);
    let status = follow(&mut disp, |n| {
        if n >= 50 && killed_at.is_none() {
            drop(a.take());
            drop(display_to_a.lock().unwrap().take());
            drop(b_to_a.lock().unwrap().take());
            killed_at = Some(n);
        }
        if n >= 120 && restarted_at.is_none() {
            a = Some(node("a", &scene, &addr_a, None, &d.path().join("a2.log")));
            restarted_at = Some(n);
            // The first link back is the only one to the restarted node a; once it holds a
            // connection to it (polled), the other comes back, on a thread (a stalled display
            // reads no frame to trigger on).
            let (slot, to_a, addr_a) = (std::sync::Arc::clone(&display_to_a), to_a.clone(), addr_a.clone());
            let (peer_slot, between) = (std::sync::Arc::clone(&b_to_a), between.clone());
            let (delay, loss) = impaired.map_or(("0".to_string(), "0".to_string()), |(d, l)| (d.to_string(), l.to_string()));
            relay_back = Some(std::thread::spawn(move || {
                let display_back = || *slot.lock().unwrap() = Some(link(&to_a, &addr_a, &delay, &loss, "4").0);
                if order == First::Display {
                    display_back();
                }
                let port = addr_a.rsplit(':').next().unwrap().to_owned();
                let t = std::time::Instant::now();
                while !established_to(&port) {
                    assert!(t.elapsed().as_secs() < 20, "the first link did not reach the restarted node a");
                    std::thread::sleep(std::time::Duration::from_millis(20));
                }
                match order {
                    First::Peer => display_back(),
                    // The display's cameras reach node a for a while before its peer does.
                    First::Display => {
                        std::thread::sleep(std::time::Duration::from_millis(500));
                        *peer_slot.lock().unwrap() = Some(link(&between, &addr_a, "0", "0", "6").0);
                    }
                }
            }));
        }
    });
    relay_back.expect("node a was restarted").join().unwrap();
    assert!(status.success(), "display: {}", std::fs::read_to_string(out.with_extension("log")).unwrap());
    let (sum, sw) = switch_summary(&out);
    assert_eq!(sum.frames, FRAMES);
    assert!(sw.node_losses >= 1 && sw.node_rejoins >= 1, "{sw:?}");
    if let Some((delay, _)) = impaired {
        // The links were impaired: a camera takes at least the delay to reach its HC.
        let link_ms = sw.camera_link_ms_median;
        assert!(link_ms >= delay.parse::<f64>().unwrap(), "camera link {link_ms} ms: the relays did not delay");
        eprintln!(
            "impaired links: camera link {link_ms:.1} ms median, latency {} ms median, {} ms max",
            sw.latency_ms_median, sw.latency_ms_max
        );
    }
    // The degraded span starts at the kill and ends once node a is back.
    let rows: Vec<DisplayFrame> = results::csv::read(&out.join("stats.csv")).unwrap();
    let degraded: Vec<u64> = rows.iter().filter(|r| r.degraded == 1).map(|r| r.frame).collect();
    let (first, last) = (*degraded.first().expect("no degraded frame"), *degraded.last().unwrap());
    // `killed_at` is the last frame this test had read from the display's stdout when it killed
    // node a: the display may have run ahead of that (a loaded machine reads the pipe late), so
    // the span is timed against the last frame node a sent as HC, which the kill itself bounds.
    let a_last = rows.iter().filter(|r| r.frame < first && r.hc_node == 0).map(|r| r.frame).max().expect("node a sent no frame");
    // The display marks frames degraded once it sees node a's link close, which over a
    // delayed, lossy relay on a loaded host can take a dozen frames; until then node b must
    // already serve every frame alone, and the display must see the loss before a returns.
    // The restart is timed the same way: by node a's first HC after its last, not by the frame
    // this test had read when it restarted the node (in one run under load the loss was seen
    // from frame 143, after a restart read "at 120").
    let a_back = rows.iter().filter(|r| r.frame > a_last && r.hc_node == 0).map(|r| r.frame).min().expect("node a never came back");
    assert!(
        first >= killed_at.unwrap() && first < a_back,
        "degraded from {first}, node a last HC at {a_last} and again at {a_back}, killed at {killed_at:?}, restarted at {restarted_at:?}"
    );
    let taken_over: Vec<(u64, u32)> =
        rows.iter().filter(|r| (a_last + 1..first).contains(&r.frame)).map(|r| (r.frame, r.hc_node)).collect();
    assert!(taken_over.iter().all(|&(_, hc)| hc == 1), "between node a's last HC ({a_last}) and the loss seen ({first}): {taken_over:?}");
    assert!(
        last >= restarted_at.unwrap() && last < FRAMES - 1,
        "degraded until {last}, restarted at {restarted_at:?}: never rejoined\n{}",
        logs(d.path(), &["a1.log", "a2.log", "b.log", "run.log"])
    );
    // After the rejoin both nodes send frames again, in turn: the survivor may send a few more
    // alone (the restarted node connects to the display and to its peer at different times,
    // and the handover takes a frame), then they alternate to the end.
    let tail: Vec<u32> = rows.iter().filter(|r| r.frame > last).map(|r| r.hc_node).collect();
    let resumed = tail.windows(2).rposition(|w| w[0] == w[1]).map_or(0, |p| p + 1);
    assert!(resumed < 30 && tail.len() - resumed > 20, "the switch did not resume: {tail:?}");
    // Node b served on while the restarted node a waited for the display (held off above): a
    // peer started anew says so in its hello and asks to rejoin itself (b asks only a peer that
    // was running, after a cut link).
    if order == First::Display {
        // The scenario took place: the display's cameras reached node a before its peer.
        let a_log = std::fs::read_to_string(d.path().join("a2.log")).unwrap();
        assert!(a_log.contains("cameras held: dropping the oldest"), "node a held no cameras before its peer came:\n{a_log}");
    }
    let b_log = std::fs::read_to_string(d.path().join("b.log")).unwrap();
    assert!(b_log.contains("rejoins: it gets a keyframe"), "node a never asked to rejoin:\n{b_log}");
    assert!(!b_log.contains("rejoining it"), "node b stopped serving for a restarted peer:\n{b_log}");
    check_against_references(d.path(), &scene, &path, &out);
}

/// The link between the nodes alone is cut at frame 50 and back at frame 120 (a relay between
/// them stopped and started again on its address): both nodes run on alone, each sending the
/// display whole frames; when node b is connected again it asks node a for a keyframe and the
/// switch resumes. The display gets every frame, right.
#[test]
fn a_cut_link_between_the_nodes_heals_and_the_switch_resumes() {
    let d = tempfile::tempdir().unwrap();
    let (scene, path) = walk(d.path());
    let (addr_a, addr_b, between) = (free_addr(), free_addr(), free_addr());
    let mut relay = Some(link(&between, &addr_a, "0", "0", "1").0);
    let mut a = node("a", &scene, &addr_a, None, &d.path().join("a.log"));
    let mut b = node("b", &scene, &addr_b, Some(&between), &d.path().join("b.log"));
    let out = d.path().join("run");
    let mut disp = display(&scene, &path, &format!("{addr_a},{addr_b}"), &out, &[]);
    let (mut cut_at, mut healed_at) = (None, None);
    let status = follow(&mut disp, |n| {
        if n >= 50 && cut_at.is_none() {
            drop(relay.take());
            cut_at = Some(n);
        }
        if n >= 120 && healed_at.is_none() {
            relay = Some(link(&between, &addr_a, "0", "0", "2").0);
            healed_at = Some(n);
        }
    });
    assert!(
        status.success(),
        "display: {}\nnodes: {}",
        std::fs::read_to_string(out.with_extension("log")).unwrap(),
        logs(d.path(), &["a.log", "b.log"])
    );
    assert_eq!(summary(&out).frames, FRAMES);
    for p in [&mut a, &mut b] {
        assert!(p.0.wait().unwrap().success(), "a node failed");
    }
    // Each node's own record: alone during the cut, then OR and HC in turn to the end.
    for n in ["a", "b"] {
        let log = std::fs::read_to_string(d.path().join(format!("{n}.log"))).unwrap();
        let rows: Vec<NodeFrame> =
            results::csv::read(&d.path().join(format!("{n}.csv"))).unwrap_or_else(|e| panic!("node {n} wrote no stats ({e}): {log}"));
        let solo: Vec<u64> = rows.iter().filter(|r| r.frame > 0 && r.duty == Duty::Solo).map(|r| r.frame).collect();
        assert!(solo.first().is_some_and(|&f| f >= cut_at.unwrap()), "node {n}: alone at {solo:?}, cut at {cut_at:?}: {log}");
        let tail: Vec<Duty> = rows.iter().filter(|r| r.frame > solo[solo.len() - 1]).map(|r| r.duty).collect();
        assert!(
            tail.len() > 20 && tail.windows(2).all(|w| w[0] != w[1] && w[0] != Duty::Solo),
            "node {n} did not resume the switch: {tail:?}: {log}"
        );
    }
    check_against_references(d.path(), &scene, &path, &out);
}

/// The display's link to node a alone is cut at frame 50 (its relay stopped) and back 1 s later
/// on the same address: the display waits for node a's frames meanwhile, node a sends it its
/// last frames again on the new connection, and the walk goes on to the end with every frame
/// right; neither node starts over.
#[test]
fn a_cut_link_to_the_display_heals_and_the_walk_goes_on() {
    let d = tempfile::tempdir().unwrap();
    let (scene, path) = walk(d.path());
    let (addr_a, addr_b) = (free_addr(), free_addr());
    let (_links, (relay, to_a), _) = links(&addr_a, &addr_b, None);
    let mut a = node("a", &scene, &addr_a, None, &d.path().join("a.log"));
    let mut b = node("b", &scene, &addr_b, Some(&addr_a), &d.path().join("b.log"));
    let out = d.path().join("run");
    let mut disp = display(&scene, &path, &format!("{to_a},{addr_b}"), &out, &[]);
    let mut relay = Some(relay);
    let mut back = None;
    let status = follow(&mut disp, |n| {
        if n >= 50 && back.is_none() {
            drop(relay.take());
            // On a thread: the display reads no frame of node a's while the link is down.
            let (to_a, addr_a) = (to_a.clone(), addr_a.clone());
            back = Some(std::thread::spawn(move || {
                std::thread::sleep(std::time::Duration::from_secs(1));
                link(&to_a, &addr_a, "0", "0", "5").0
            }));
        }
    });
    let _relay = back.expect("the link was cut").join().unwrap();
    assert!(
        status.success(),
        "display: {}\nnodes: {}",
        std::fs::read_to_string(out.with_extension("log")).unwrap(),
        logs(d.path(), &["a.log", "b.log"])
    );
    let (sum, sw) = switch_summary(&out);
    assert_eq!(sum.frames, FRAMES);
    assert!(sw.node_losses >= 1 && sw.node_rejoins >= 1, "the display never lost node a: {sw:?}");
    for p in [&mut a, &mut b] {
        assert!(p.0.wait().unwrap().success(), "a node failed: {}", logs(d.path(), &["a.log", "b.log"]));
    }
    let a_log = std::fs::read_to_string(d.path().join("a.log")).unwrap();
    assert!(a_log.contains("the display reconnected"), "node a never saw the display come back: {a_log}");
    let whole = ["a", "b"].map(|n| std::fs::read_to_string(d.path().join(format!("{n}.log"))).unwrap()).join("\n");
    assert!(!whole.contains("starting over"), "a node started over for a reconnecting display: {whole}");
    // The switch ran on: both nodes sent frames in turn after the cut.
    let rows: Vec<DisplayFrame> = results::csv::read(&out.join("stats.csv")).unwrap();
    let tail: Vec<u32> = rows.iter().filter(|r| r.frame > 100).map(|r| r.hc_node).collect();
    assert!(tail.windows(2).filter(|w| w[0] != w[1]).count() > 100, "the switch did not run on: {tail:?}");
    check_against_references(d.path(), &scene, &path, &out);
}

#[test]
fn a_restarted_display_is_served_from_the_start_of_its_path() {
    display_restart(None);
}

#[test]
fn a_restarted_display_over_links_with_delay_and_loss() {
    display_restart(Some(("5", "0.01")));
}

fn display_restart(impaired: Option<(&str, &str)>) {
    let d = tempfile::tempdir().unwrap();
    let (scene, path) = walk(d.path());
    let (addr_a, addr_b) = (free_addr(), free_addr());
    let (_links, (_relay, to_a), [to_a_from_b, to_b]) = links(&addr_a, &addr_b, impaired);
    let mut a = node("a", &scene, &addr_a, None, &d.path().join("a.log"));
    let mut b = node("b", &scene, &addr_b, Some(&to_a_from_b), &d.path().join("b.log"));
    let nodes = format!("{to_a},{to_b}");
    let first = d.path().join("first");
    let mut disp = display(&scene, &path, &nodes, &first, &[]);
    let lines = BufReader::new(disp.0.stdout.take().unwrap()).lines();
    for l in lines.map_while(Result::ok) {
        if l == "frame 50" {
            break;
        }
    }
    drop(disp);
    let second = d.path().join("second");
    let mut again = display(&scene, &path, &nodes, &second, &[]);
    let status = follow(&mut again, |_| {});
    assert!(status.success(), "display: {}", std::fs::read_to_string(second.with_extension("log")).unwrap());
    assert_eq!(summary(&second).frames, FRAMES);
    // The nodes finish cleanly after the second display's goodbye.
    for (n, p) in [("a", &mut a), ("b", &mut b)] {
        let st = p.0.wait().unwrap();
        assert!(st.success(), "node {n}: {}", std::fs::read_to_string(d.path().join(format!("{n}.log"))).unwrap());
    }
    check_against_references(d.path(), &scene, &path, &second);
}

#[test]
fn silent_and_garbage_connections_do_not_stop_the_cluster() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "city", 30_000, 2);
    let path = camera_path(&scene, "orbit", 40);
    let (addr_a, addr_b) = (free_addr(), free_addr());
    let mut a = node("a", &scene, &addr_a, None, &d.path().join("a.log"));
    let _b = node("b", &scene, &addr_b, Some(&addr_a), &d.path().join("b.log"));
    // A half-open connection that never says hello, and one that sends a frame far over the
    // size limit followed by junk: each is refused or times out on its own.
    let connect = || {
        let t = std::time::Instant::now();
        loop {
            match std::net::TcpStream::connect(&addr_a) {
                Ok(c) => break c,
                Err(_) if t.elapsed().as_secs() < 20 => std::thread::sleep(std::time::Duration::from_millis(50)),
                Err(e) => panic!("node a does not listen: {e}"),
            }
        }
    };
    let _silent = connect();
    let mut junk = connect();
    std::io::Write::write_all(&mut junk, &[0xff, 0xff, 0xff, 0x7f, 1, 2, 3, 4, 5]).unwrap();
    let out = d.path().join("run");
    let mut disp = display(&scene, &path, &format!("{addr_a},{addr_b}"), &out, &[]);
    let status = follow(&mut disp, |_| {});
    assert!(status.success(), "display: {}", std::fs::read_to_string(out.with_extension("log")).unwrap());
    assert_eq!(summary(&out).frames, 40);
    assert!(a.0.wait().unwrap().success(), "node a: {}", std::fs::read_to_string(d.path().join("a.log")).unwrap());
    let log = std::fs::read_to_string(d.path().join("a.log")).unwrap();
    assert!(log.contains("over the"), "the oversized frame was not refused by name: {log}");
}

/// A display that floods each node with a million cameras at once. Each node keeps what its
/// frame loop can use, drops the rest as it arrives and counts it, answers a ping sent behind
/// the flood (so it has read it all) with little more resident memory than before, and ends
/// cleanly at the goodbye.
#[test]
fn a_camera_flood_is_dropped_counted_and_bounded() {
    use osw_wire::{CameraPacket, Goodbye, Hello, Message, Ping, Role, decode_frame, encode_frame};
    const FLOOD: u64 = 1_000_000;
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "city", 30_000, 2);
    let path = camera_path(&scene, "orbit", 1);
    let cam = osw_scene::path::read(&path).unwrap()[0];
    let (addr_a, addr_b) = (free_addr(), free_addr());
    let logs = [d.path().join("a.log"), d.path().join("b.log")];
    let mut nodes = [node("a", &scene, &addr_a, None, &logs[0]), node("b", &scene, &addr_b, Some(&addr_a), &logs[1])];
    let settings = osw_render::settings::Agreed::default().said((192, 192));
    assert_eq!(settings[0], ("--size".into(), SIZE.into()));
    let hello = Hello::new(osw_scene::SceneFile::open(&scene).unwrap().content_hash(), "flood", Role::Display, settings);
    let frame = |m: &Message| {
        let mut b = Vec::new();
        encode_frame(m, &mut b).unwrap();
        b
    };
    // Each connection's messages after the handshake, read as they come (the nodes' frames
    // are drained too).
    let (tx, rx) = std::sync::mpsc::channel::<(usize, Message)>();
    let mut socks = Vec::new();
    for (k, addr) in [&addr_a, &addr_b].into_iter().enumerate() {
        let mut peer = RawPeer::connect(addr);
        assert!(peer.handshake(&hello, None).is_some(), "node {k} did not finish the handshake");
        let (mut r, tx, mut buf) = (peer.sock.try_clone().unwrap(), tx.clone(), std::mem::take(&mut peer.buf));
        std::thread::spawn(move || {
            let mut chunk = vec![0u8; 1 << 16];
            loop {
                while let Ok(Some((m, used))) = decode_frame(&buf) {
                    buf.drain(..used);
                    if tx.send((k, m)).is_err() {
                        return;
                    }
                }
                let Ok(n @ 1..) = std::io::Read::read(&mut r, &mut chunk) else { return };
                buf.extend_from_slice(&chunk[..n]);
            }
        });
        socks.push(peer.sock);
    }
    // Waits for a message matching `what` from each node in `from`.
    let wait_for = |what: &dyn Fn(&Message) -> bool, label: &str, from: [bool; 2]| {
        let mut got = from.map(|f| !f);
        while !got.iter().all(|g| *g) {
            let (k, m) = rx.recv_timeout(std::time::Duration::from_secs(60)).unwrap_or_else(|_| panic!("no {label} from both nodes"));
            got[k] |= what(&m);
        }
    };
    let hwm_kb = |p: &Proc| -> u64 {
        let status = std::fs::read_to_string(format!("/proc/{}/status", p.0.id())).unwrap();
        let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    let cameras = |frames: std::ops::Range<u64>, out: &mut Vec<u8>| {
        for k in frames {
            encode_frame(
                &Message::Camera(CameraPacket {
                    frame: k,
                    position: cam.position.to_array(),
                    orientation: cam.orientation.to_array(),
                    fovy_deg: cam.fovy_deg,
                    tau_px: 0.0,
                    sampled_us: 0,
                }),
                out,
            )
            .unwrap();
        }
    };
    let send_all = |socks: &mut Vec<std::net::TcpStream>, bytes: &[u8]| {
        std::thread::scope(|sc| {
            for c in socks.iter_mut() {
                sc.spawn(move || std::io::Write::write_all(c, bytes).unwrap());
            }
        })
    };
    // A few frames as a display sends them, so that the renderers have what they keep.
    let mut first = Vec::new();
    cameras(0..8, &mut first);
    send_all(&mut socks, &first);
    // Node b is HC of the odd frames.
    wait_for(&|m| matches!(m, Message::EndOfFrame(e) if e.frame == 7), "frame 7", [false, true]);
    let before = nodes.each_ref().map(hwm_kb);
    let mut flood = Vec::with_capacity(FLOOD as usize * 90);
    cameras(8..8 + FLOOD, &mut flood);
    flood.extend(frame(&Message::Ping(Ping { sent_us: 7 })));
    send_all(&mut socks, &flood);
    wait_for(&|m| matches!(m, Message::Pong(p) if p.ping_sent_us == 7), "pong after the flood", [true; 2]);
    let after = nodes.each_ref().map(hwm_kb);
    for c in &mut socks {
        std::io::Write::write_all(c, &frame(&Message::Goodbye(Goodbye { reason: "flood done".into() }))).unwrap();
    }
    for (k, p) in nodes.iter_mut().enumerate() {
        let log = || std::fs::read_to_string(&logs[k]).unwrap();
        assert!(p.0.wait().unwrap().success(), "node {k}: {}", log());
        let log = log();
        let dropped: u64 = log
            .lines()
            .find_map(|l| l.split(" cameras dropped").next().filter(|_| l.contains(" cameras dropped"))?.rsplit(' ').next()?.parse().ok())
            .unwrap_or_else(|| panic!("node {k} did not count dropped cameras: {log}"));
        assert!(dropped >= FLOOD - 16, "node {k} dropped {dropped} of {FLOOD}");
        // A million cameras are about 85 MB on the wire and over 100 MB queued as events.
        assert!(after[k] < before[k] + (32 << 10), "node {k}: peak resident {} kB before the flood, {} kB after", before[k], after[k]);
        eprintln!("node {k}: {dropped} cameras dropped; peak resident {} kB before, {} kB after", before[k], after[k]);
    }
}
