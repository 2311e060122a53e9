//! The door: processes started with a cluster token tell a stranger nothing (not the token, not
//! the scene's content hash, not a setting) and admit none, while the walk goes on with every
//! frame. Strangers: one that sends nothing, one that sends garbage, one that replays a
//! handshake recorded from a peer that held the token, and one that holds another token;
//! against the nodes, and posing as nodes against the display.

mod common;
use common::*;
use osw_wire::auth::Token;
use osw_wire::{Hello, Message, Role};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

const TOKEN: &str = "s3cret-token-XYZ";
const SIZE: &str = "64x64";
const FRAMES: u32 = 200;

/// What a stranger must never receive: the token, each word of the scene's content hash as
/// the hello encodes it, and the settings' names.
fn secrets(scene: &Path) -> Vec<Vec<u8>> {
    let h = osw_scene::SceneFile::open(scene).unwrap().content_hash();
    let mut s = vec![TOKEN.as_bytes().to_vec(), b"--size".to_vec(), b"--cluster-tests".to_vec()];
    s.extend(h.iter().map(|w| w.to_le_bytes().to_vec()));
    s
}

fn assert_tells_nothing(got: &[u8], secrets: &[Vec<u8>], who: &str) {
    for secret in secrets {
        assert!(!got.windows(secret.len()).any(|w| w == secret.as_slice()), "{who} received {secret:?} in {} bytes", got.len());
    }
}

/// A hello as the display says it for `scene` at SIZE.
fn display_hello(scene: &Path) -> Hello {
    let settings = osw_render::settings::Agreed::default().said((64, 64));
    Hello::new(osw_scene::SceneFile::open(scene).unwrap().content_hash(), "stranger", Role::Display, settings)
}

fn node(name: &str, scene: &Path, token_file: &Path, peer: Option<&str>, log: &Path) -> (Proc, String) {
    let mut c = Command::new(bin("osw-node"));
    c.args(["--name", name, "--scene", s(scene), "--size", SIZE, "--token-file", s(token_file), "--listen", "127.0.0.1:0"]);
    c.args(["--stats", s(&log.with_extension("csv"))]);
    if let Some(p) = peer {
        c.args(["--peer", p]);
    }
    let mut p = Proc(c.stdout(Stdio::piped()).stderr(std::fs::File::create(log).unwrap()).spawn().unwrap());
    let mut line = String::new();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(p.0.stdout.take().unwrap()), &mut line).unwrap();
    let addr = line.trim().strip_prefix("listening on ").unwrap_or_else(|| panic!("node {name} did not start: {line:?}")).to_owned();
    (p, addr)
}

/// Each stranger against the node at `addr`: what it received, and whether the node said a
/// hello to it (admitted it).
fn strangers(addr: &str, scene: &Path, recorded: &[u8]) -> Vec<(&'static str, Vec<u8>, bool)> {
    let wait = Duration::from_secs(2);
    let said_hello = |p: &mut RawPeer| std::iter::from_fn(|| p.next(wait)).any(|m| matches!(m, Message::Hello(_)));
    let mut out = Vec::new();
    let mut silent = RawPeer::connect(addr);
    let hello = said_hello(&mut silent);
    out.push(("a client that sends nothing", silent.got, hello));
    let mut garbage = RawPeer::connect(addr);
    garbage.send_bytes(&(0..4096u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect::<Vec<_>>());
    let hello = said_hello(&mut garbage);
    out.push(("a client that sends garbage", garbage.got, hello));
    let mut replay = RawPeer::connect(addr);
    replay.send_bytes(recorded);
    let hello = said_hello(&mut replay);
    out.push(("a client that replays a recorded handshake", replay.got, hello));
    let mut wrong = RawPeer::connect(addr);
    let hello = wrong.handshake(&display_hello(scene), Some(&Token::new("wrong-token"))).is_some();
    let hello = hello || said_hello(&mut wrong);
    out.push(("a client with a wrong token", wrong.got, hello));
    out
}

#[test]
fn strangers_at_the_nodes_learn_nothing_and_are_not_admitted_while_the_walk_goes_on() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "city", 20_000, 1);
    let path = camera_path(&scene, "orbit", FRAMES);
    let key = d.path().join("cluster.key");
    std::fs::write(&key, format!("{TOKEN}\n")).unwrap();
    let secrets = secrets(&scene);

    // A handshake as a peer holding the token says it, recorded against a node of its own.
    let (_recorder, at) = node("a", &scene, &key, None, &d.path().join("recorder.log"));
    let mut real = RawPeer::connect(&at);
    assert!(real.handshake(&display_hello(&scene), Some(&Token::new(TOKEN))).is_some(), "a client holding the token is admitted");
    let recorded = real.sent.clone();

    let (a_log, b_log) = (d.path().join("a.log"), d.path().join("b.log"));
    let (a, addr_a) = node("a", &scene, &key, None, &a_log);
    let (b, addr_b) = node("b", &scene, &key, Some(&addr_a), &b_log);
    // Both nodes' strangers at once, while the nodes wait for the display.
    let found = std::thread::scope(|sc| {
        let at = [(&addr_a, "node a"), (&addr_b, "node b")].map(|(addr, name)| (sc.spawn(|| strangers(addr, &scene, &recorded)), name));
        at.map(|(t, name)| (t.join().unwrap(), name))
    });
    for (tried, name) in found {
        for (who, got, admitted) in tried {
            eprintln!("{who} at {name}: {} bytes received", got.len());
            assert_tells_nothing(&got, &secrets, &format!("{who} at {name}"));
            assert!(!admitted, "{who} at {name} was admitted");
        }
    }
    let out = d.path().join("run");
    let mut display = Proc(
        Command::new(bin("osw-display"))
            .args(["--scene", s(&scene), "--path", s(&path), "--nodes", &format!("{addr_a},{addr_b}"), "--size", SIZE])
            .args(["--token-file", s(&key), "--out", s(&out)])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    // And strangers with a wrong token at node a for as long as the walk runs.
    let mut during = 0;
    while display.0.try_wait().unwrap().is_none() {
        let Ok(sock) = std::net::TcpStream::connect(&addr_a) else { break };
        let mut wrong = RawPeer::on(sock);
        let admitted = wrong.handshake(&display_hello(&scene), Some(&Token::new("wrong-token"))).is_some();
        assert!(!admitted, "a client with a wrong token was admitted during the walk");
        assert_tells_nothing(&wrong.got, &secrets, "a client with a wrong token during the walk");
        during += 1;
    }
    let status = display.0.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(display.0.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert!(status.success(), "the walk stopped: {err}");
    assert_eq!(csv_column(&out.join("stats.csv"), "frame").len(), FRAMES as usize, "the walk lost frames");
    eprintln!("{during} strangers with a wrong token at node a during the walk");
    // Each node refused the replay and the wrong token for their proofs, and counted them in
    // the statistics it writes as it exits.
    for (mut p, log) in [(a, &a_log), (b, &b_log)] {
        let deadline = std::time::Instant::now() + Duration::from_secs(30);
        while p.0.try_wait().unwrap().is_none() {
            assert!(std::time::Instant::now() < deadline, "{} did not exit after the walk", log.display());
            std::thread::sleep(Duration::from_millis(20));
        }
        let refusals = csv_column(&log.with_extension("csv"), "auth_refusals");
        assert!(refusals.last().is_some_and(|&n| n >= 2.0), "{}: auth_refusals {refusals:?}", log.display());
        let text = std::fs::read_to_string(log).unwrap();
        assert!(text.contains("a wrong or missing cluster token") && text.contains("127.0.0.1"), "refusals not named: {text}");
    }
}

#[test]
fn a_display_tells_a_stranger_posing_as_a_node_nothing() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "city", 20_000, 1);
    let path = camera_path(&scene, "orbit", 2);
    let key = d.path().join("cluster.key");
    std::fs::write(&key, TOKEN).unwrap();
    let secrets = secrets(&scene);
    let fakes = [(); 2].map(|_| std::net::TcpListener::bind("127.0.0.1:0").unwrap());
    let addrs: Vec<String> = fakes.iter().map(|l| l.local_addr().unwrap().to_string()).collect();
    let mut display = Proc(
        Command::new(bin("osw-display"))
            .args(["--scene", s(&scene), "--path", s(&path), "--nodes", &addrs.join(","), "--size", SIZE])
            .args(["--token-file", s(&key), "--out", s(&d.path().join("run"))])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let wait = Duration::from_secs(5);
    // Fake node a holds another token; fake node b answers garbage.
    let (sock, _) = fakes[0].accept().unwrap();
    let mut wrong = RawPeer::on(sock);
    let Some(Message::Challenge(theirs)) = wrong.next(wait) else { panic!("the display did not open with a challenge") };
    let mine = osw_wire::auth::nonce();
    wrong.send(&Message::Challenge(osw_wire::messages::Challenge { version: osw_wire::limits::PROTOCOL_VERSION, nonce: mine }));
    let tag = osw_wire::auth::tag(Some(&Token::new("wrong-token")), osw_wire::auth::Purpose::Proof, &mine, &theirs.nonce, &[]);
    wrong.send(&Message::Proof(osw_wire::messages::Proof { tag }));
    let said = std::iter::from_fn(|| wrong.next(wait)).any(|m| matches!(m, Message::Hello(_)));
    assert!(!said, "the display said its hello to a node with another token");
    assert_tells_nothing(&wrong.got, &secrets, "a node with a wrong token");
    let (sock, _) = fakes[1].accept().unwrap();
    let mut garbage = RawPeer::on(sock);
    garbage.send_bytes(&[0xff; 64]);
    let said = std::iter::from_fn(|| garbage.next(wait)).any(|m| matches!(m, Message::Hello(_)));
    assert!(!said, "the display said its hello to a node that answers garbage");
    assert_tells_nothing(&garbage.got, &secrets, "a node that answers garbage");
    let status = display.0.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(display.0.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert!(!status.success() && err.contains("refused") && err.contains("token"), "{status}: {err}");
}

#[test]
fn a_node_open_beyond_loopback_without_a_token_says_anyone_can_join() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "city", 20_000, 1);
    for (listen, warns) in [("0.0.0.0:0", true), ("127.0.0.1:0", false)] {
        let log = d.path().join("node.log");
        let mut p = Proc(
            Command::new(bin("osw-node"))
                .args(["--name", "a", "--scene", s(&scene), "--size", SIZE, "--listen", listen])
                .stdout(Stdio::piped())
                .stderr(std::fs::File::create(&log).unwrap())
                .spawn()
                .unwrap(),
        );
        let mut line = String::new();
        std::io::BufRead::read_line(&mut std::io::BufReader::new(p.0.stdout.take().unwrap()), &mut line).unwrap();
        assert!(line.starts_with("listening on"), "{line:?}");
        let text = std::fs::read_to_string(&log).unwrap();
        assert_eq!(text.contains("anyone who can reach this port can join"), warns, "listening on {listen}: {text}");
    }
}

/// With mutual TLS the walk runs with every frame; a client whose certificate another CA
/// signed is refused in the TLS handshake, before any osw byte, and a plain client gets no osw
/// byte either.
#[test]
fn with_tls_only_the_clusters_certificates_get_in() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "city", 20_000, 1);
    let path = camera_path(&scene, "orbit", FRAMES);
    let (certs, other) = (d.path().join("certs"), d.path().join("other"));
    osw_ok(&["certs", "--out", s(&certs)]);
    osw_ok(&["certs", "--names", "stranger", "--out", s(&other)]);
    let tls_args = |who: &str| {
        let f = |n: String| certs.join(n).display().to_string();
        vec![
            "--tls-cert".to_string(),
            f(format!("{who}.pem")),
            "--tls-key".into(),
            f(format!("{who}.key")),
            "--tls-ca".into(),
            f("ca.pem".into()),
        ]
    };
    let start = |name: &str, peer: Option<&str>| {
        let mut c = Command::new(bin("osw-node"));
        c.args(["--name", name, "--scene", s(&scene), "--size", SIZE, "--token", TOKEN, "--listen", "127.0.0.1:0"]);
        c.args(tls_args(&format!("node-{name}")));
        if let Some(p) = peer {
            c.args(["--peer", p]);
        }
        let log = d.path().join(format!("{name}.log"));
        let mut p = Proc(c.stdout(Stdio::piped()).stderr(std::fs::File::create(&log).unwrap()).spawn().unwrap());
        let mut line = String::new();
        std::io::BufRead::read_line(&mut std::io::BufReader::new(p.0.stdout.take().unwrap()), &mut line).unwrap();
        (p, line.trim().strip_prefix("listening on ").unwrap_or_else(|| panic!("node {name}: {line:?}")).to_owned(), log)
    };
    let (_a, addr_a, a_log) = start("a", None);
    let (_b, addr_b, _) = start("b", Some(&addr_a));
    let secrets = secrets(&scene);

    // A TLS client with a certificate of another CA (trusting the cluster's, so that only its
    // own certificate is at fault).
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
    let stranger = osw_wire::tls::Tls::load(&other.join("stranger.pem"), &other.join("stranger.key"), &certs.join("ca.pem")).unwrap();
    let refused = rt.block_on(async {
        let mut c = osw_wire::net::connect(&addr_a, Duration::from_secs(10), Some(&stranger)).await?;
        // TLS 1.3 sends the client's certificate after the server's finished: its refusal comes
        // as the first read.
        osw_wire::net::recv(&mut c, "node a").await
    });
    assert!(refused.is_err(), "a certificate of another CA got a message: {refused:?}");
    // A plain client, as on a cluster without TLS, and one that sends garbage: no osw byte.
    for garbage in [false, true] {
        let mut plain = RawPeer::connect(&addr_a);
        if garbage {
            plain.send_bytes(&[0x16, 3, 3, 0, 4, 1, 2, 3, 4]);
        }
        let got = std::iter::from_fn(|| plain.next(Duration::from_secs(2))).count();
        assert_eq!(got, 0, "a plain client decoded osw messages");
        assert_tells_nothing(&plain.got, &secrets, "a plain client at a TLS node");
    }

    let out = d.path().join("run");
    let status = Command::new(bin("osw-display"))
        .args(["--scene", s(&scene), "--path", s(&path), "--nodes", &format!("{addr_a},{addr_b}"), "--size", SIZE, "--token", TOKEN])
        .args(tls_args("display"))
        .args(["--out", s(&out)])
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success(), "the walk over TLS failed");
    assert_eq!(csv_column(&out.join("stats.csv"), "frame").len(), FRAMES as usize, "the walk lost frames");
    let (_, sw) = switch_summary(&out);
    assert!(sw.wire_bytes_per_frame_mean > 0.0, "the display counted no bytes on its sockets");
    let log = std::fs::read_to_string(&a_log).unwrap();
    assert!(log.contains("TLS"), "node a did not say it refused a TLS peer: {log}");
}
