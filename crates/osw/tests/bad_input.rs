//! Bad input to `osw build`, `osw info` and `osw path`: a clear error naming the file and what
//! is wrong (exit 1), or a documented clean-up counted in the report; never a panic.

mod common;
use common::*;
use std::path::Path;

/// A glTF document with one buffer holding `positions` (f32 VEC3) and optional u32 `indices`,
/// one mesh, and a node hierarchy: root (translate x+10) → child (scale 2) → mesh.
fn gltf_json(buffer_uri: Option<&str>, byte_len: usize, vertex_count: usize, index_count: Option<usize>, extra_prim: &str) -> String {
    let uri = buffer_uri.map(|u| format!(r#""uri":"{u}","#)).unwrap_or_default();
    let pos_bytes = vertex_count * 12;
    let (indices_view, indices_acc, indices_ref) = match index_count {
        Some(n) => (
            format!(r#",{{"buffer":0,"byteOffset":{pos_bytes},"byteLength":{}}}"#, n * 4),
            format!(r#",{{"bufferView":1,"componentType":5125,"count":{n},"type":"SCALAR"}}"#),
            r#","indices":1"#.to_string(),
        ),
        None => (String::new(), String::new(), String::new()),
    };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"name":"root","translation":[10,0,0],"children":[1]}},{{"name":"part","scale":[2,2,2],"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}{indices_ref}}}{extra_prim}]}}],
        "buffers":[{{{uri}"byteLength":{byte_len}}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_bytes}}}{indices_view}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":{vertex_count},"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}{indices_acc}]}}"#
    )
}

/// Two triangles of a unit quad, indexed.
fn quad_buffer(index: [u32; 6]) -> Vec<u8> {
    let mut b = Vec::new();
    for p in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]] {
        p.iter().for_each(|c| b.extend(c.to_le_bytes()));
    }
    index.iter().for_each(|i| b.extend(i.to_le_bytes()));
    b
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(b);
    out
}

fn build_args(input: &Path, out: &Path) -> Vec<String> {
    vec!["build".into(), input.display().to_string(), "-o".into(), out.display().to_string()]
}

fn run_build(input: &Path, out: &Path) -> std::process::Output {
    let a = build_args(input, out);
    osw(&a.iter().map(String::as_str).collect::<Vec<_>>())
}

/// The error of a build that must fail, which `needle` must be in.
fn build_err(input: &Path, out: &Path, needle: &str) -> String {
    let a = build_args(input, out);
    let err = osw_err(&a.iter().map(String::as_str).collect::<Vec<_>>(), needle);
    assert!(!out.exists(), "a failed build left {}", out.display());
    err
}

#[test]
fn gltf_external_embedded_and_glb_all_import_the_hierarchy() {
    let d = tempfile::tempdir().unwrap();
    let bin = quad_buffer([0, 1, 2, 0, 2, 3]);
    // External buffer, plus a POINTS primitive that is skipped with a warning.
    std::fs::write(d.path().join("quad.bin"), &bin).unwrap();
    let points = r#",{"attributes":{"POSITION":0},"mode":0}"#;
    std::fs::write(d.path().join("ext.gltf"), gltf_json(Some("quad.bin"), bin.len(), 4, Some(6), points)).unwrap();
    // Embedded data URI, non-indexed: the first three vertices are one triangle.
    let uri = format!("data:application/octet-stream;base64,{}", base64::encode(&bin[..36]));
    std::fs::write(d.path().join("emb.gltf"), gltf_json(Some(&uri), 36, 3, None, "")).unwrap();
    std::fs::write(d.path().join("q.glb"), glb(&gltf_json(None, bin.len(), 4, Some(6), ""), &bin)).unwrap();
    for (name, tris) in [("ext.gltf", 2), ("emb.gltf", 1), ("q.glb", 2)] {
        let out = d.path().join(format!("{name}.osw"));
        assert!(run_build(&d.path().join(name), &out).status.success(), "{name}");
        let s = osw_scene::SceneFile::open(&out).unwrap();
        check_invariants(&s);
        assert_eq!(s.header().leaf_triangles, tris, "{name}");
        // Transforms compose: x' = 10 + 2x, so the unit quad spans x in [10, 12] in the world.
        let (root, o) = (s.node(0), s.origin());
        assert_eq!(
            (o.x + root.bbox_min[0] as f64, o.x + root.bbox_max[0] as f64, o.y + root.bbox_max[1] as f64),
            (10.0, 12.0, 2.0),
            "{name}"
        );
    }
    let report = std::fs::read_to_string(d.path().join("ext.gltf.build.json")).unwrap();
    assert!(report.contains("Points"), "the skipped POINTS primitive is not reported: {report}");
}

#[test]
fn broken_gltf_and_glb_name_the_file_and_the_problem() {
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    let out = p("out.osw");
    let bin = quad_buffer([0, 1, 2, 0, 2, 3]);
    std::fs::write(p("nojson.gltf"), "{ not json").unwrap();
    build_err(&p("nojson.gltf"), &out, "nojson.gltf");
    std::fs::write(p("missing.gltf"), gltf_json(Some("gone.bin"), bin.len(), 4, Some(6), "")).unwrap();
    build_err(&p("missing.gltf"), &out, "cannot load a buffer");
    // A buffer shorter than its views say.
    std::fs::write(p("short.bin"), &bin[..40]).unwrap();
    std::fs::write(p("short.gltf"), gltf_json(Some("short.bin"), 40, 4, Some(6), "")).unwrap();
    build_err(&p("short.gltf"), &out, "short.gltf");
    // An index past the last vertex.
    let bad = quad_buffer([0, 1, 2, 0, 2, 9]);
    std::fs::write(p("badidx.bin"), &bad).unwrap();
    std::fs::write(p("badidx.gltf"), gltf_json(Some("badidx.bin"), bad.len(), 4, Some(6), "")).unwrap();
    build_err(&p("badidx.gltf"), &out, "out of range");
    // The same index in the first of two primitives: merged with the second's four vertices it
    // would name one of those. Refused naming the primitive, the error said once.
    let bad = quad_buffer([0, 1, 2, 0, 2, 4]);
    std::fs::write(p("twoprim.bin"), &bad).unwrap();
    let second = r#",{"attributes":{"POSITION":0}}"#;
    std::fs::write(p("twoprim.gltf"), gltf_json(Some("twoprim.bin"), bad.len(), 4, Some(6), second)).unwrap();
    let err = build_err(&p("twoprim.gltf"), &out, "primitive 0: index 4 at position 5 is out of range");
    assert_eq!(err.matches("out of range").count(), 1, "said more than once: {err}");
    // NaN position.
    let mut nan = bin.clone();
    nan[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(p("nan.bin"), &nan).unwrap();
    std::fs::write(p("nan.gltf"), gltf_json(Some("nan.bin"), nan.len(), 4, Some(6), "")).unwrap();
    build_err(&p("nan.gltf"), &out, "non-finite");
    // Every truncation of a GLB fails cleanly.
    let g = glb(&gltf_json(None, bin.len(), 4, Some(6), ""), &bin);
    for n in (0..g.len() - 1).step_by(7) {
        std::fs::write(p("t.glb"), &g[..n]).unwrap();
        let r = run_build(&p("t.glb"), &out);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.code() == Some(1) && err.contains("t.glb") && !err.contains("panicked"), "GLB cut at {n}: {err}");
    }
    // No triangles at all: an empty scene.
    std::fs::write(p("empty.gltf"), r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[]}],"scene":0}"#).unwrap();
    build_err(&p("empty.gltf"), &out, "empty scene");
    build_err(&p("none.gltf"), &out, "none.gltf");
    build_err(&p("x.stl"), &out, "unknown input format");
}

#[test]
fn ply_degenerates_are_dropped_and_counted_and_bad_ply_is_named() {
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    let head = |v: usize, f: usize| {
        format!(
            "ply\nformat ascii 1.0\nelement vertex {v}\nproperty float x\nproperty float y\nproperty float z\nelement face {f}\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    // One good triangle, one with a repeated index, one of zero area.
    let ok = format!("{}0 0 0\n1 0 0\n0 1 0\n2 0 0\n3 0 1 2\n3 0 0 1\n3 0 1 3\n", head(4, 3));
    std::fs::write(p("deg.ply"), ok).unwrap();
    assert!(run_build(&p("deg.ply"), &p("deg.osw")).status.success());
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(p("deg.build.json")).unwrap()).unwrap();
    assert_eq!(report["degenerate_triangles_dropped"], 2);
    assert!(report["left_out"].to_string().contains("2 degenerate triangles"));
    assert_eq!(osw_scene::SceneFile::open(&p("deg.osw")).unwrap().header().leaf_triangles, 1);

    std::fs::write(p("idx.ply"), format!("{}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", head(3, 1))).unwrap();
    build_err(&p("idx.ply"), &p("o.osw"), "out of range");
    std::fs::write(p("nan.ply"), format!("{}0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", head(3, 1))).unwrap();
    build_err(&p("nan.ply"), &p("o.osw"), "non-finite");
    std::fs::write(p("short.ply"), format!("{}0 0 0\n1 0 0\n", head(3, 1))).unwrap();
    build_err(&p("short.ply"), &p("o.osw"), "unexpected end of data");
    // Only degenerate triangles: nothing left, an empty scene.
    std::fs::write(p("flat.ply"), format!("{}0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n", head(3, 1))).unwrap();
    build_err(&p("flat.ply"), &p("o.osw"), "empty scene");
}

#[test]
fn corrupted_or_truncated_scene_files_are_refused_by_name() {
    let d = tempfile::tempdir().unwrap();
    let good = build_gen(d.path(), "teapots", 20_000, 1);
    let bytes = std::fs::read(&good).unwrap();
    let bad = d.path().join("bad.osw");
    let info = |b: &[u8], needle: &str| {
        std::fs::write(&bad, b).unwrap();
        osw_err(&["info", "--scene", bad.to_str().unwrap()], needle);
    };
    info(&bytes[..bytes.len() - 1], "truncated");
    info(&bytes[..100], "truncated");
    info(&bytes[..0], "not an osw scene file");
    let mut v = bytes.clone();
    v[8] = 99; // version
    info(&v, "version");
    v[8] = 9; // a file of version 9 (no textures): refused with how to rebuild it
    info(&v, "scene format version 9, this build reads version 10; rebuild the scene with `osw build`");
    let h = *osw_scene::SceneFile::open(&good).unwrap().header();
    let mut v = bytes.clone();
    v[h.nodes_offset as usize + 100] ^= 0x40; // inside the node table
    info(&v, "content hash");
    let mut v = bytes.clone();
    v[h.blocks_offset as usize + 50] ^= 0x40; // inside the block table, at the end of the file
    info(&v, "content hash");
    let mut v = bytes.clone();
    v[40] ^= 1; // a header count
    info(&v, "header hash");
    // A flipped geometry byte passes opening (only tables are read) and fails on first read.
    let mut v = bytes.clone();
    v[h.blob_offset as usize + 200] ^= 0x10;
    std::fs::write(&bad, &v).unwrap();
    osw_ok(&["info", "--scene", bad.to_str().unwrap()]);
    osw_err(&["info", "--scene", bad.to_str().unwrap(), "--check-geometry"], "fails its hash");
    // Truncations at many points never panic.
    for cut in (0..bytes.len()).step_by(bytes.len() / 50) {
        let r = osw_scene::file::validate(std::path::Path::new("t"), &bytes[..cut]);
        assert!(r.is_err(), "cut at {cut} accepted");
    }
}

#[test]
fn bad_command_lines_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let o = d.path().join("o.osw");
    let out = osw(&["build", "--gen", "castle", "-o", o.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected city, teapots, plant, forest or isosurface"));
    osw_err(&["build", "--gen", "city", "--chunk-triangles", "0", "-o", o.to_str().unwrap()], "chunk-triangles");
    osw_err(&["build", "--gen", "city", "--bucket-triangles", "0", "-o", o.to_str().unwrap()], "bucket-triangles");
    osw_err(&["build", "--gen", "plant", "--triangles", "5000000000", "-o", o.to_str().unwrap()], "u32");
    osw_err(&["build", "--gen", "plant", "--instanced", "--triangles", "30000000000", "-o", o.to_str().unwrap()], "20000M");
    osw_err(&["build", "--gen", "city", "--instanced", "-o", o.to_str().unwrap()], "needs --gen plant");
    let out = osw(&["build", "--gen", "city", "--instances", "some", "-o", o.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected keep or expand"));
    osw_err(&["build", "--gen", "isosurface", "--triangles", "1000000000", "-o", o.to_str().unwrap()], "in memory");
    for f in ["1.5", "-0.1", "NaN"] {
        let arg = format!("--loose-split={f}");
        osw_err(&["build", "--gen", "city", &arg, "-o", o.to_str().unwrap()], "--loose-split must be a fraction");
    }
    for angle in ["181", "-1", "NaN"] {
        let arg = format!("--crease-angle={angle}");
        osw_err(&["build", "--gen", "city", &arg, "-o", o.to_str().unwrap()], "--crease-angle must be from 0 to 180 degrees");
    }
    osw_err(&["path", "--scene", "/nonexistent.osw", "--kind", "walk", "-o", "p.csv"], "/nonexistent.osw");
    for tests in ["frustrum", "none,cone", ""] {
        let args = ["render", "--scene", "s.osw", "--path", "p.csv", "--mode", "vfc", "--cluster-tests", tests, "--out", "o"];
        let out = osw(&args);
        assert_eq!(out.status.code(), Some(2), "{tests:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("expected a list of frustum, cone, backface, small and occlusion, or none"),
            "{tests:?}"
        );
    }
    for fps in ["0", "-1", "NaN", "inf", "0.001"] {
        let out = std::process::Command::new(bin("osw-display"))
            .args(["--scene", "s.osw", "--path", "p.csv", "--nodes", "a,b", &format!("--fps={fps}"), "--out", "o"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(&format!("--fps {fps}: expected")), "--fps {fps}: {err}");
    }
}

#[test]
fn a_closed_stdout_is_not_a_crash() {
    // `osw build ... | head -0`: the reader is gone before osw prints; osw still succeeds.
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("c.osw");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_osw"))
        .args(["build", "--gen", "city", "--triangles", "20000", "-o", out.to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let r = child.wait_with_output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(out.exists());
}

#[test]
fn ctrl_c_stops_a_build_and_removes_its_partial_and_temporary_files() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("big.osw");
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_osw"))
        .args(["build", "--gen", "plant", "--triangles", "30000000", "-o", out.to_str().unwrap()])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut child = Proc(child);
    // Wait until the build has written temporary data, then interrupt it as Ctrl-C does.
    let spill = out.with_extension("osw.spill");
    let t = std::time::Instant::now();
    while std::fs::metadata(&spill).map_or(0, |m| m.len()) < 1 << 20 {
        assert!(t.elapsed().as_secs() < 60, "no spill file after 60 s");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let pid = child.0.id().to_string();
    assert!(std::process::Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let status = child.0.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(child.0.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("interrupted") && !err.contains("panicked"), "{err}");
    let left: Vec<_> = std::fs::read_dir(d.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// Every tool reads run results through one schema: a renamed key in a run's summary.json is
/// an error naming the file and the key, for a run on one GPU and for a switch run, never a
/// default in a report.
#[test]
fn a_renamed_key_in_a_summary_is_named_by_the_tools_that_read_it() {
    use osw_render::results::{Details, SwitchSummary};
    use osw_render::{Mode, Summary};
    let d = tempfile::tempdir().unwrap();
    let render = Summary { mode: Mode::Prev, frames: 2, ..Default::default() };
    let switch = Summary { mode: Mode::Switch, frames: 2, of: Details::Switch(SwitchSummary::default()), ..Default::default() };
    for (name, summary, key, tools) in [
        ("prev", &render, "frame_ms_median", &["compare"][..]),
        ("switch", &switch, "latency_ms_median", &["compare", "latency", "bandwidth"][..]),
    ] {
        let (run, good) = (d.path().join(name), d.path().join(format!("{name}-good")));
        for dir in [&run, &good] {
            std::fs::create_dir_all(dir).unwrap();
            summary.write(dir).unwrap();
        }
        let file = run.join("summary.json");
        let text = std::fs::read_to_string(&file).unwrap().replace(&format!("\"{key}\""), &format!("\"{key}_old\""));
        std::fs::write(&file, text).unwrap();
        for tool in tools {
            let out = d.path().join(format!("{tool}-out"));
            let args = match *tool {
                "compare" => vec!["compare", "--a", s(&run), "--b", s(&good), "--out", s(&out)],
                t => vec![t, "--run", s(&run), "--out", s(&out)],
            };
            let err = osw_err(&args, &format!("missing field `{key}`"));
            assert!(err.contains(s(&file)), "{tool}: {err}");
        }
    }
}

/// The malformed glTF of a peer's importer (Debian's assimp-testmodels, `models/bad`, which
/// `scripts/setup.sh` fills): each builds, or is refused with exit 1 and an error naming its
/// file; none panics or leaves a scene behind.
#[test]
fn a_peers_corpus_of_malformed_gltf_is_refused_by_name_or_built() {
    let Some(files) = bad_models("a_peers_corpus_of_malformed_gltf_is_refused_by_name_or_built") else { return };
    assert!(files.len() >= 10, "{files:?}");
    let d = tempfile::tempdir().unwrap();
    let (mut built, mut refused) = (0, 0);
    for (k, f) in files.iter().enumerate() {
        let out = d.path().join(format!("{k}.osw"));
        let r = osw(&["build", s(f), "-o", s(&out)]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!err.contains("panicked"), "{}: {err}", f.display());
        match r.status.code() {
            Some(0) => built += 1,
            Some(1) => {
                let name = f.file_name().unwrap().to_str().unwrap();
                assert!(err.contains("osw: error:") && err.contains(name), "{}: the error does not name the file: {err}", f.display());
                assert!(!out.exists(), "{}: a refused build left a scene", f.display());
                refused += 1;
            }
            c => panic!("{}: exit {c:?}: {err}", f.display()),
        }
    }
    eprintln!("{built} built, {refused} refused by name");
    assert!(refused > 0, "a corpus of malformed files refused nothing");
}
