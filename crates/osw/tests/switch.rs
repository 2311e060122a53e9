//! The occlusion switch as three processes on loopback (`osw run`): frames and visible sets
//! identical to single-process `prev`, identical to `vfc` at tau 0 with no false culling,
//! `--full` sends more for the same frames, and a killed node is survived (the display gets
//! every frame), then reported by name, leaving no process behind.

mod common;
use common::*;
use osw_render::results::{self, Duty, NodeFrame};
use std::path::Path;
use std::time::{Duration, Instant};

#[test]
fn the_switch_is_prev_split_across_processes() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 150_000, 5);
    let path = camera_path(&scene, "walk", 16);
    let [run, full, prev, vfc, exact] = ["run", "full", "prev", "vfc", "exact"].map(|n| d.path().join(n));
    osw_ok(&["run", "--scene", s(&scene), "--path", s(&path), "--size", "256x256", "--out", s(&run)]);
    osw_ok(&["run", "--scene", s(&scene), "--path", s(&path), "--size", "256x256", "--full", "--out", s(&full)]);
    osw_ok(&["render", "--scene", s(&scene), "--path", s(&path), "--mode", "prev", "--size", "256x256", "--out", s(&prev)]);
    osw_ok(&["render", "--scene", s(&scene), "--path", s(&path), "--mode", "vfc", "--size", "256x256", "--out", s(&vfc)]);
    osw_ok(&["exact", "--scene", s(&scene), "--path", s(&path), "--size", "256x256", "--out", s(&exact)]);
    // Same visible set on every frame, same pixels.
    let pvs = |p: &Path| std::fs::read_to_string(p.join("pvs.txt")).unwrap();
    assert_eq!(pvs(&run), pvs(&prev), "the switch's visible sets differ from prev's");
    assert_eq!(pvs(&full), pvs(&prev), "--full changes the visible sets");
    for i in 0..16 {
        let f = |p: &Path| std::fs::read(p.join(format!("frames/{i:05}.png"))).unwrap();
        assert!(f(&run) == f(&prev), "frame {i} differs from prev");
        assert!(f(&full) == f(&prev), "frame {i} with --full differs from prev");
    }
    let c = compare(&run, &vfc, &exact, &d.path().join("cmp"));
    assert_same_frames(&c, 16, "the switch against vfc");
    assert_eq!(c["culling_a"]["false_culled_leaves_total"], 0, "{c}");
    // The statistics: deltas send fewer ids and bytes than full sets, and say how many fewer.
    let ((sd, d_sw), (_, f_sw)) = (switch_summary(&run), switch_summary(&full));
    for (key, v) in
        [("latency_ms_median", d_sw.latency_ms_median), ("frame_ms_median", sd.frame_ms_median), ("rvg_ms_median", sd.rvg_ms_median)]
    {
        assert!(v > 0.0, "{key}: {sd:?}");
    }
    assert!(d_sw.node_a_hc_ms_median.is_some() && d_sw.node_b_or_ms_median.is_some(), "osw run merges the nodes' times: {d_sw:?}");
    assert_eq!(d_sw.ids_full_mean, f_sw.ids_full_mean);
    assert_eq!(f_sw.ids_sent_mean, f_sw.ids_full_mean, "--full sends every id");
    assert!(d_sw.ids_sent_mean < f_sw.ids_sent_mean);
    assert!(d_sw.bytes_per_frame_mean < f_sw.bytes_per_frame_mean);
    assert!((d_sw.incremental_saved_fraction - (1.0 - d_sw.ids_sent_mean / d_sw.ids_full_mean)).abs() < 1e-9);
    // Each node did both roles, in turn.
    let rows: Vec<NodeFrame> = results::csv::read(&run.join("node-a.csv")).unwrap();
    // Frame 0 has no OR before it: node a runs it alone, then the roles alternate.
    let expect = |i: u64| match i {
        0 => Duty::Solo,
        _ if i.is_multiple_of(2) => Duty::Hc,
        _ => Duty::Or,
    };
    assert!(rows.len() >= 15 && rows.iter().enumerate().all(|(i, r)| r.frame == i as u64 && r.duty == expect(r.frame)), "{rows:?}");
    check_bandwidth(&scene, &run, &full, &exact, &d.path().join("bw"));
    check_latency(&run, &d.path().join("lat"));
}

/// `osw run --cluster-tests` reaches the nodes and the display: with every test (HC's notes
/// of hidden clusters sent to RVG as a mask), or with the frustum test alone, the counts say
/// so, and the visible sets, the triangles RVG draws and the frames are prev's with the same
/// tests.
#[test]
fn the_switch_runs_the_cluster_tests_it_is_given() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 150_000, 4);
    let path = camera_path(&scene, "walk", 12);
    for tests in ["frustum,cone,backface,small,occlusion", "frustum"] {
        let [run, prev] = ["run", "prev"].map(|n| d.path().join(format!("{n}-{}", tests.replace(',', "-"))));
        let walk = ["--scene", s(&scene), "--path", s(&path), "--size", "256x256", "--cluster-tests", tests];
        osw_ok(&[&["run"], &walk[..], &["--out", s(&run)]].concat());
        osw_ok(&[&["render", "--mode", "prev"], &walk[..], &["--out", s(&prev)]].concat());
        let pvs = |p: &Path| std::fs::read_to_string(p.join("pvs.txt")).unwrap();
        assert_eq!(pvs(&run), pvs(&prev), "{tests}: visible sets");
        // Where culling did not pay (osw_cull::payoff) RVG draws the nodes whole: the counts
        // of those frames are the display's own. The small-triangle test skips a node where it
        // did not pay for the process that draws it (osw_cull::gathered), which then draws the
        // triangles the test would drop: the two add up to the same.
        let stats = |p: &Path, k: &str| csv_column(&p.join("stats.csv"), k);
        let past_backface = |p: &Path| -> Vec<f64> {
            stats(p, "triangles_drawn").iter().zip(stats(p, "triangles_small_culled")).map(|(d, s)| d + s).collect()
        };
        let (skipped, drawn, prev_drawn) = (stats(&run, "cull_skipped"), past_backface(&run), past_backface(&prev));
        assert_eq!(skipped, stats(&prev, "cull_skipped"), "{tests}: frames culled");
        for i in (0..12).filter(|&i| skipped[i] == 0.0 || tests == "frustum") {
            assert_eq!(drawn[i], prev_drawn[i], "{tests}: frame {i}: RVG draws what prev's RVG draws");
        }
        for i in 0..12 {
            let f = |p: &Path| std::fs::read(p.join(format!("frames/{i:05}.png"))).unwrap();
            assert!(f(&run) == f(&prev), "{tests}: frame {i} differs from prev's");
        }
        let r = summary(&run);
        let occlusion = r.clusters_occlusion_culled_fraction;
        let cone = r.clusters_cone_culled_fraction;
        match tests {
            "frustum" => assert!(occlusion == 0.0 && cone == 0.0, "frustum only: {occlusion} hidden, {cone} facing away"),
            _ => assert!(occlusion > 0.0 && cone > 0.0, "all tests: {occlusion} hidden, {cone} facing away"),
        }
    }
}

/// A CSV file as rows of cells by header name.
fn csv(p: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(p).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines.map(|l| head.iter().map(|h| h.to_string()).zip(l.split(',').map(String::from)).collect()).collect()
}

fn num(row: &std::collections::HashMap<String, String>, k: &str) -> f64 {
    row.get(k).unwrap_or_else(|| panic!("no column {k}")).parse().unwrap()
}

/// `osw bandwidth`: the bytes the HC nodes counted on sending equal those the display counted
/// on receiving; the model is the paper's formula of the same n, h, b; --full sends every id;
/// exact visibility's saving is its leaves' churn over its size.
fn frame_len(m: &osw_wire::Message) -> usize {
    osw_wire::Frame::new(m).unwrap().len()
}

fn check_bandwidth(scene: &Path, run: &Path, full: &Path, exact: &Path, out: &Path) {
    osw_ok(&["bandwidth", "--run", s(run), "--full", s(full), "--exact", s(exact), "--out", s(out)]);
    let (bw, display, display_full) = (csv(&out.join("bandwidth.csv")), csv(&run.join("stats.csv")), csv(&full.join("stats.csv")));
    let j: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("bandwidth.json")).unwrap()).unwrap();
    let (h, b) = (j["incremental"]["header_bytes"].as_f64().unwrap(), j["incremental"]["batch"].as_f64().unwrap());
    assert_eq!(bw.len(), display.len());
    for (i, (r, d)) in bw.iter().zip(&display).enumerate() {
        assert_eq!(num(r, "hc_to_rvg_bytes"), num(d, "bytes"), "frame {i}: sent and received bytes differ");
        assert_eq!(num(r, "ids_sent"), num(d, "ids_sent"), "frame {i}");
        assert_eq!(num(r, "full_ids_sent"), num(&display_full[i], "ids_full"), "frame {i}: --full must send the whole set");
        let n = num(r, "ids_sent");
        assert!((num(r, "model_bytes") - (8.0 * n + n * h / b + 3.0 * (72.0 + h))).abs() < 0.06, "frame {i}: {r:?}");
        // Both links carry the same deltas and end of frame; RVG also gets the camera first.
        let camera = frame_len(&osw_wire::Message::Camera(osw_wire::CameraPacket {
            frame: i as u64,
            position: [0.0; 3],
            orientation: [0.0, 0.0, 0.0, 1.0],
            fovy_deg: 60.0,
            tau_px: 0.0,
            sampled_us: osw_wire::clock::now_us(),
        })) as f64;
        // And HC's cluster mask of the frame's visible set: a bit per opaque cluster of its nodes.
        assert_eq!(num(r, "hc_to_rvg_bytes") - num(r, "hc_to_or_bytes"), camera + num(d, "mask_bytes"), "frame {i}: {r:?}");
    }
    let file = osw_scene::SceneFile::open(scene).unwrap();
    let sets = std::fs::read_to_string(run.join("pvs.txt")).unwrap();
    let mut masks = 0;
    for (i, (line, d)) in sets.lines().zip(&display).enumerate() {
        let clusters: u32 = line.split_whitespace().map(|t| file.opaque_clusters(t.parse().unwrap())).sum();
        let bits = vec![0; clusters.div_ceil(8) as usize];
        let mask = frame_len(&osw_wire::Message::Clusters(osw_wire::messages::ClusterMask { frame: i as u64, bits })) as f64;
        // Where culling did not pay (osw_cull::payoff) HC has no pyramid, and sends no mask.
        let culled = num(d, "cull_skipped") == 0.0;
        assert_eq!(num(d, "mask_bytes"), if culled { mask } else { 0.0 }, "frame {i}: a mask of {clusters} clusters takes {mask}: {d:?}");
        masks += usize::from(culled);
    }
    assert!(masks > 0, "no frame culled");
    // The id-carrying messages, against their sizes coded again from the visible sets (pvs.txt).
    let batch = b as usize;
    for (dir, rows, keyframes) in [(run, &display, false), (full, &display_full, true)] {
        let sets: Vec<Vec<u32>> = std::fs::read_to_string(dir.join("pvs.txt"))
            .unwrap()
            .lines()
            .map(|l| l.split_whitespace().map(|t| t.parse().unwrap()).collect())
            .collect();
        let mut before: &[u32] = &[];
        for (i, v) in sets.iter().enumerate() {
            let (added, removed): (Vec<u32>, Vec<u32>) = (
                v.iter().copied().filter(|id| !before.contains(id)).collect(),
                before.iter().copied().filter(|id| !v.contains(id)).collect(),
            );
            let frame = i as u64;
            let expected: usize = if keyframes {
                osw_wire::Keyframe::parts(frame, v, osw_wire::limits::KEYFRAME_PART_BYTES).iter().map(frame_len).sum()
            } else {
                let part =
                    |ids: &[u32], k: usize| osw_wire::IdList::from_ids(&ids[(k * batch).min(ids.len())..((k + 1) * batch).min(ids.len())]);
                (0..added.len().div_ceil(batch).max(removed.len().div_ceil(batch)))
                    .map(|k| {
                        frame_len(&osw_wire::Message::Delta(osw_wire::Delta { frame, added: part(&added, k), removed: part(&removed, k) }))
                    })
                    .sum()
            };
            assert_eq!(num(&rows[i], "id_bytes"), expected as f64, "frame {i} (keyframes: {keyframes})");
            before = v;
        }
    }
    let sets: Vec<std::collections::HashSet<String>> = std::fs::read_to_string(exact.join("exact_leaves.txt"))
        .unwrap()
        .lines()
        .map(|l| l.split_whitespace().map(String::from).collect())
        .collect();
    let churn: usize =
        sets.iter().enumerate().map(|(i, e)| if i == 0 { e.len() } else { e.symmetric_difference(&sets[i - 1]).count() }).sum();
    let size: usize = sets.iter().map(|e| e.len()).sum();
    assert!((j["exact_saved_fraction_ids"].as_f64().unwrap() - (1.0 - churn as f64 / size.max(1) as f64)).abs() < 1e-9, "{j}");
    let ids: f64 = bw.iter().map(|r| num(r, "ids_sent")).sum();
    let visible: f64 = bw.iter().map(|r| num(r, "visible")).sum();
    assert!((j["saved_fraction_ids"].as_f64().unwrap() - (1.0 - ids / visible)).abs() < 1e-9);
    assert!(j["saved_fraction_bytes"].as_f64().unwrap() > 0.0, "{j}");
    for plot in ["bandwidth_ids.png", "bandwidth_bytes.png", "bandwidth_bytes.svg"] {
        assert!(std::fs::metadata(out.join(plot)).unwrap().len() > 1000, "{plot}");
    }
}

/// `osw latency`: on one host the true clock offset is 0, so each estimate must lie within its
/// own bound (half the probe's round trip); one-way link latencies and the stages, which follow
/// one another, fit inside the frame's camera-to-display latency, and the nodes stamped them;
/// the floor is the sum of the busy stages' medians.
fn check_latency(run: &Path, out: &Path) {
    osw_ok(&["latency", "--run", s(run), "--out", s(out)]);
    let j: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("latency.json")).unwrap()).unwrap();
    let j = &j[0];
    for n in ["a", "b"] {
        let (off, rtt) = (j[format!("clock_offset_{n}_us")].as_f64().unwrap(), j[format!("clock_rtt_{n}_us")].as_f64().unwrap());
        assert!(off.abs() <= rtt / 2.0 + 1.0, "node {n}: offset {off} µs outside ±{} µs", rtt / 2.0);
    }
    let slack = 1.0 + j["clock_rtt_a_us"].as_f64().unwrap().max(j["clock_rtt_b_us"].as_f64().unwrap()) / 1e3;
    let rows = csv(&run.join("stats.csv"));
    let busy = ["camera_link_ms", "or_front_ms", "or_tail_ms", "hc_stage_ms", "notes_ms", "eof_link_ms", "rvg_ms", "readback_ms"];
    let waits = ["camera_wait_ms", "display_wait_ms"];
    for (i, r) in rows.iter().enumerate() {
        let (cam, eof, peer, total) = (num(r, "camera_link_ms"), num(r, "eof_link_ms"), num(r, "peer_link_ms"), num(r, "latency_ms"));
        assert!(cam > -slack && eof > -slack && peer > -slack && cam + eof <= total + slack, "frame {i}: {r:?}");
        let stages: f64 = busy.iter().chain(&waits).map(|c| num(r, c)).sum();
        assert!(stages <= total + slack, "frame {i}: stages {stages} ms beyond the latency {total} ms: {r:?}");
        // OR's and HC's stages are stamped on every frame but the first (no occluders yet).
        if i > 0 {
            assert!(num(r, "or_front_ms") + num(r, "or_tail_ms") > 0.0 && num(r, "hc_stage_ms") > 0.0, "frame {i}: {r:?}");
        }
    }
    let median = |c: &str| {
        let mut v: Vec<f64> = rows.iter().map(|r| num(r, c)).collect();
        v.sort_by(f64::total_cmp);
        // Nearest rank, as osw_render::stats::quantile.
        v[((v.len() - 1) as f64 * 0.5).round() as usize]
    };
    let floor: f64 = busy.iter().map(|c| median(c)).sum();
    let reported = j["floor_ms"].as_f64().unwrap();
    assert!((reported - floor).abs() < 1e-6 * floor.max(1.0) + 0.01, "floor {reported} ms, by the medians {floor} ms");
    assert!(floor > 0.0 && floor <= median("latency_ms") + slack, "floor {floor} ms");
    assert_eq!(j["latency"].as_array().unwrap().len(), 4);
    assert!(std::fs::metadata(out.join("latency.png")).unwrap().len() > 1000);
    assert!(std::fs::metadata(out.join("stages.png")).unwrap().len() > 1000);
}

#[test]
fn a_killed_node_is_survived_then_reported_by_name() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "city", 60_000, 1);
    let path = camera_path(&scene, "orbit", 600);
    let out = d.path().join("run");
    let mut run = std::process::Command::new(env!("CARGO_BIN_EXE_osw"))
        .args(["run", "--scene", s(&scene), "--path", s(&path), "--size", "64x64", "--no-frames", "--out", s(&out)])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Once a tenth of the path is displayed (osw run says so without a terminal), kill node b:
    // node a runs both roles to the end of the path.
    // osw run starts each process with the cluster configuration it writes into the run.
    let config = out.join("cluster.toml");
    let pattern = format!("--config {} --name b", s(&config));
    let (tx, said) = std::sync::mpsc::channel();
    let stdout = run.stdout.take().unwrap();
    std::thread::spawn(move || {
        for l in std::io::BufRead::lines(std::io::BufReader::new(stdout)).map_while(Result::ok) {
            let _ = tx.send(l);
        }
    });
    let t = Instant::now();
    loop {
        let left = Duration::from_secs(60).saturating_sub(t.elapsed());
        let line = said.recv_timeout(left).unwrap_or_else(|_| panic!("osw run displayed no tenth of the path in 60 s"));
        if line.starts_with("run: 60/600 frames") {
            break;
        }
    }
    let killed = std::process::Command::new("pkill").args(["-9", "-f", "--", &pattern]).status().unwrap();
    assert!(killed.success(), "node b was not running");
    let t = Instant::now();
    let status = loop {
        if let Some(s) = run.try_wait().unwrap() {
            break s;
        }
        assert!(t.elapsed() < Duration::from_secs(60), "osw run still running 60 s after node b was killed");
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(run.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert!(!status.success(), "a killed node must fail the run");
    assert!(err.contains("node b"), "the error does not name node b: {err}");
    let rows = csv(&out.join("stats.csv"));
    assert_eq!(rows.len(), 600, "the display did not get every frame");
    assert!(rows.iter().any(|r| num(r, "degraded") == 1.0), "no degraded frame recorded");
    // The processes' exits, polled.
    let t = Instant::now();
    loop {
        let left = std::process::Command::new("pgrep").args(["-f", s(&config)]).output().unwrap();
        if left.stdout.is_empty() {
            break;
        }
        assert!(t.elapsed() < Duration::from_secs(10), "processes left behind: {}", String::from_utf8_lossy(&left.stdout));
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn the_handshake_refuses_another_scene_and_a_wrong_token() {
    let d = tempfile::tempdir().unwrap();
    let one = build_gen(d.path(), "city", 20_000, 1);
    let two = build_gen(d.path(), "city", 20_000, 2);
    let path = camera_path(&one, "orbit", 4);
    let bin = |n: &str| Path::new(env!("CARGO_BIN_EXE_osw")).with_file_name(n);
    for (node_args, display_args, needle) in [
        (vec!["--scene", s(&one)], vec!["--scene", s(&two)], "different scene"),
        (vec!["--scene", s(&one), "--token", "right"], vec!["--scene", s(&one), "--token", "wrong"], "token"),
        (vec!["--scene", s(&one), "--token", "right"], vec!["--scene", s(&one)], "token"),
        (vec!["--scene", s(&one), "--adaptive", "0.5"], vec!["--scene", s(&one)], "setting --adaptive: 0.5 there, 0 here"),
        (
            vec!["--scene", s(&one)],
            vec!["--scene", s(&one), "--cluster-tests", "frustum"],
            "setting --cluster-tests: frustum,cone,backface,small,occlusion there, frustum here",
        ),
    ] {
        let mut node = std::process::Command::new(bin("osw-node"))
            .args(["--name", "a", "--size", "32x32"])
            .args(&node_args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        std::io::BufRead::read_line(&mut std::io::BufReader::new(node.stdout.take().unwrap()), &mut line).unwrap();
        let addr = line.trim().strip_prefix("listening on ").unwrap().to_owned();
        let out = std::process::Command::new(bin("osw-display"))
            .args(["--path", s(&path), "--nodes", &format!("{addr},{addr}"), "--size", "32x32", "--out", s(&d.path().join("o"))])
            .args(&display_args)
            .output()
            .unwrap();
        let _ = node.kill();
        let _ = node.wait();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains(needle) && err.contains("refused"), "expected {needle:?}: {err}");
    }
}

/// A keyframe larger than a frame crosses in parts (here parts of at most 16 bytes of ids,
/// every frame a keyframe): the display's visible sets are prev's, and the nodes say how many
/// parts they sent.
#[test]
fn keyframes_cross_in_parts_and_the_display_holds_the_nodes_visible_sets() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "city", 20_000, 1);
    let path = camera_path(&scene, "orbit", 6);
    let prev = d.path().join("prev");
    osw_ok(&["render", "--scene", s(&scene), "--path", s(&path), "--mode", "prev", "--size", "64x64", "--no-frames", "--out", s(&prev)]);
    let bin = |n: &str| Path::new(env!("CARGO_BIN_EXE_osw")).with_file_name(n);
    let node = |name: &str, peer: Option<&str>| {
        let mut c = std::process::Command::new(bin("osw-node"));
        c.args(["--name", name, "--scene", s(&scene), "--size", "64x64", "--full", "--keyframe-part-bytes", "16"]);
        c.args(["--stats", s(&d.path().join(format!("node-{name}.csv")))]);
        if let Some(p) = peer {
            c.args(["--peer", p]);
        }
        let mut child = c.stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::null()).spawn().unwrap();
        let mut line = String::new();
        std::io::BufRead::read_line(&mut std::io::BufReader::new(child.stdout.take().unwrap()), &mut line).unwrap();
        (child, line.trim().strip_prefix("listening on ").unwrap().to_owned())
    };
    let (mut a, addr_a) = node("a", None);
    let (mut b, addr_b) = node("b", Some(&addr_a));
    let run = d.path().join("run");
    let out = std::process::Command::new(bin("osw-display"))
        .args(["--scene", s(&scene), "--path", s(&path), "--nodes", &format!("{addr_a},{addr_b}"), "--size", "64x64"])
        .args(["--no-frames", "--out", s(&run)])
        .output()
        .unwrap();
    for n in [&mut a, &mut b] {
        let _ = n.wait();
    }
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let pvs = |p: &Path| std::fs::read_to_string(p.join("pvs.txt")).unwrap();
    assert_eq!(pvs(&run), pvs(&prev), "the display's visible sets differ from prev's");
    let rows: Vec<NodeFrame> = ["a", "b"]
        .iter()
        .flat_map(|n| results::csv::read::<NodeFrame>(&d.path().join(format!("node-{n}.csv"))).unwrap())
        .filter(|r| r.duty != Duty::Or)
        .collect();
    assert_eq!(rows.len(), 6);
    assert!(rows.iter().all(|r| r.batches as u64 >= r.ids_sent.div_ceil(16)), "a part holds at most 16 ids here: {rows:?}");
    assert!(rows.iter().any(|r| r.batches > 1), "{rows:?}");
}
