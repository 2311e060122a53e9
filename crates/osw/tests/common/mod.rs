//! Helpers shared by the integration tests: run the `osw` binary, build scenes, and check a
//! scene file's invariants from its tables and geometry (independently of the build code).
#![allow(dead_code)]

use osw_scene::SceneFile;
use osw_scene::format::{ErrorBound, NONE, NodeKind, NodeRecord};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};

/// A binary of this workspace beside `osw` (osw-node, osw-display).
pub fn bin(n: &str) -> PathBuf {
    Path::new(env!("CARGO_BIN_EXE_osw")).with_file_name(n)
}

/// Kills the process when dropped, so a failing test leaves nothing behind.
pub struct Proc(pub Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A run's summary.json, through the schema the tools read it with.
pub fn summary(run: &Path) -> osw_render::Summary {
    osw_render::Summary::read(run).unwrap_or_else(|e| panic!("{e}"))
}

/// The keys of a run on one GPU.
pub fn render_summary(run: &Path) -> osw_render::results::RenderSummary {
    summary(run).render().cloned().unwrap_or_else(|| panic!("{}: not a run of osw render", run.display()))
}

/// The keys of a switch run.
pub fn switch_summary(run: &Path) -> (osw_render::Summary, osw_render::results::SwitchSummary) {
    let s = summary(run);
    let sw = s.switch().cloned().unwrap_or_else(|| panic!("{}: not a switch run", run.display()));
    (s, sw)
}

/// Where real models made by others are, in order: `OSW_MODELS`, `../shared/models` beside the
/// repository (our machines and CI), `models/` in it (`scripts/setup.sh` fills it from Debian's
/// assimp-testmodels). A user's clone may have none.
fn model_dirs() -> Vec<PathBuf> {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    match std::env::var_os("OSW_MODELS") {
        Some(d) => vec![PathBuf::from(d)],
        None => vec![repo.join("../shared/models"), repo.join("models")],
    }
    .into_iter()
    .filter(|d| d.is_dir())
    .collect()
}

/// A test that cannot run here says so in one line, past the harness's capture of eprintln!
/// so that a passing run shows it; with `OSW_REQUIRE_MODELS` set (CI, where
/// `../shared/models` is), it fails instead.
pub fn skip(test: &str, why: &str) {
    if std::env::var_os("OSW_REQUIRE_MODELS").is_some() {
        panic!("{test}: {why}, and OSW_REQUIRE_MODELS says every model test must run");
    }
    let _ = writeln!(std::io::stderr(), "skipped {test}: {why}");
}

/// The first folder of [`model_dirs`], or None where there is none (the test says so).
pub fn real_models_dir(test: &str) -> Option<PathBuf> {
    let dir = model_dirs().into_iter().next();
    if dir.is_none() {
        skip(test, "no real models (set OSW_MODELS, or run scripts/setup.sh to fill models/)");
    }
    dir
}

/// The real model `name` from the first folder that holds it, or None (the test says so).
pub fn real_model(test: &str, name: &str) -> Option<PathBuf> {
    let found = model_dirs().into_iter().map(|d| d.join(name)).find(|p| p.is_file());
    if found.is_none() {
        skip(test, &format!("no {name} in {:?}", model_dirs()));
    }
    found
}

/// The models of [`real_models_dir`] that `osw build` reads, sorted.
pub fn real_models(test: &str) -> Option<Vec<PathBuf>> {
    let dir = real_models_dir(test)?;
    let mut found: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| ["glb", "gltf", "obj", "ply"].contains(&e)))
        .collect();
    found.sort();
    Some(found)
}

/// The malformed glTF files of `models/bad` (`scripts/setup.sh`), sorted, or None (the test
/// says so).
pub fn bad_models(test: &str) -> Option<Vec<PathBuf>> {
    setup_models(test, "bad", "malformed")
}

/// The glTF files under `models/<folder>` (`scripts/setup.sh`; `what` names them in the line
/// a test that cannot run says), sorted, or None.
pub fn setup_models(test: &str, folder: &str, what: &str) -> Option<Vec<PathBuf>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models").join(folder);
    if !dir.is_dir() {
        skip(test, &format!("no {what} models in {} (run scripts/setup.sh)", dir.display()));
        return None;
    }
    let mut found = Vec::new();
    let mut todo = vec![dir];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().path()) {
            match e.extension().and_then(|x| x.to_str()) {
                _ if e.is_dir() => todo.push(e),
                Some("gltf" | "glb") => found.push(e),
                _ => {}
            }
        }
    }
    found.sort();
    Some(found)
}

pub fn osw(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_osw")).args(args).env("OSW_MESH_CACHE", "/nonexistent").output().expect("run osw")
}

/// Runs osw and asserts success; returns stdout.
pub fn osw_ok(args: &[&str]) -> String {
    let out = osw(args);
    assert!(out.status.success(), "osw {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8")
}

/// Runs osw and asserts a clean failure: exit code 1, an `osw: error:` line naming `needle`,
/// and no panic. Returns stderr.
pub fn osw_err(args: &[&str], needle: &str) -> String {
    let out = osw(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "osw {args:?}: expected exit 1, stderr: {err}");
    assert!(err.contains("osw: error:") && err.contains(needle), "osw {args:?}: stderr lacks {needle:?}: {err}");
    assert!(!err.contains("panicked"), "osw {args:?} panicked: {err}");
    err
}

pub fn build_gen(dir: &Path, kind: &str, triangles: u64, seed: u64) -> PathBuf {
    build_gen_lod(dir, kind, triangles, seed, "chains")
}

/// [`build_gen`] with `--lod` `lod` (chains or clusters).
pub fn build_gen_lod(dir: &Path, kind: &str, triangles: u64, seed: u64, lod: &str) -> PathBuf {
    let out = dir.join(format!("{kind}-{triangles}-{seed}-{lod}.osw"));
    let (t, seed) = (triangles.to_string(), seed.to_string());
    osw_ok(&["build", "--gen", kind, "--triangles", &t, "--seed", &seed, "--lod", lod, "-o", out.to_str().unwrap()]);
    out
}

/// A camera path of `frames` frames of `kind` (`osw path`) through `scene`, written beside it.
pub fn camera_path(scene: &Path, kind: &str, frames: u32) -> PathBuf {
    let stem = scene.file_stem().unwrap().to_str().unwrap();
    let out = scene.with_file_name(format!("{stem}-{kind}-{frames}.csv"));
    osw_ok(&["path", "--scene", s(scene), "--kind", kind, "--frames", &frames.to_string(), "-o", s(&out)]);
    out
}

/// Every structural invariant of a scene file, checked from the file alone:
/// - ids dense: every node is reached exactly once from the root through children and LODs;
/// - box containment: child boxes in parent boxes, LOD boxes in their owner's box, every
///   vertex of every block in its LOD's box;
/// - error monotonicity: a BVH child's error <= its parent's; a chain's errors strictly rise
///   from 0 at level 0; an HLOD's error >= every child's error;
/// - every leaf triangle reachable: level-0 triangles of all leaves add up to the header's count;
/// - cluster hierarchies: every cluster's cut bounds enclosed by its cut node's, and a cut
///   node's `hi` by its BVH node's parent's bound of what lies below it.
pub fn check_invariants(s: &SceneFile) {
    let nodes = s.nodes();
    let n = nodes.len();
    let mut seen = vec![false; n];
    let mut stack = vec![0u32];
    let mut leaf_triangles = 0u64;
    while let Some(id) = stack.pop() {
        assert!(!seen[id as usize], "node {id} reached twice");
        seen[id as usize] = true;
        let node = nodes[id as usize];
        let b = node.aabb();
        for c in node.children() {
            let child = nodes[c as usize];
            assert!(b.contains(&child.aabb()), "node {id} box does not contain child {c}");
            assert!(child.error <= node.error, "error of child {c} ({}) above parent {id} ({})", child.error, node.error);
            stack.push(c);
        }
        let mut prev: Option<f32> = None;
        for l in node.lods() {
            assert!(!seen[l as usize], "LOD {l} reached twice");
            seen[l as usize] = true;
            let lod = nodes[l as usize];
            assert_eq!(lod.kind(), NodeKind::Lod);
            assert!(b.contains(&lod.aabb()), "LOD {l} box outside owner {id}");
            let g = s.geometry(l).expect("geometry passes its checks");
            assert_eq!(g.indices.len() as u64, lod.triangles * 3);
            assert!(!g.indices.is_empty(), "empty LOD {l}");
            assert!(g.positions.iter().all(|p| lod.aabb().contains_point(glam::Vec3::from_array(*p))), "vertex outside LOD {l} box");
            if lod.is_cut() {
                assert_eq!(g.cuts.len(), g.clusters.len(), "cut node {l}: a cut for each cluster");
                check_cut(nodes, id, l, g.cuts);
                if node.kind() == NodeKind::Leaf {
                    let original: u64 =
                        g.clusters.iter().zip(g.cuts).filter(|(_, cut)| cut.lo.error == 0.0).map(|(c, _)| c.index_count as u64 / 3).sum();
                    assert_eq!(original, node.triangles, "leaf {id}: its chunk in its cut node");
                }
                continue;
            }
            match prev {
                None if node.kind() == NodeKind::Leaf => assert_eq!(lod.error, 0.0, "level 0 of leaf {id}"),
                None => {
                    let kids = node.children().map(|c| nodes[c as usize].error).fold(0.0, f32::max);
                    assert!(lod.error >= kids && lod.error > 0.0, "HLOD {l} error {} below children's {kids}", lod.error);
                }
                Some(p) => assert!(lod.error > p, "chain of {id} not increasing"),
            }
            prev = Some(lod.error);
            if node.kind() == NodeKind::Leaf && l == node.first_lod {
                assert_eq!(lod.triangles, node.triangles);
            }
        }
        match node.kind() {
            NodeKind::Leaf => {
                assert!(node.lod_count >= 1 && node.child_count == 0);
                assert_ne!(node.object, NONE);
                leaf_triangles += node.triangles;
            }
            NodeKind::Group => assert!(node.child_count >= 2 && node.lods().filter(|&l| !nodes[l as usize].is_cut()).count() <= 1),
            NodeKind::Lod => panic!("LOD {id} in the BVH"),
        }
    }
    assert!(seen.iter().all(|&x| x), "{} nodes unreachable", seen.iter().filter(|x| !**x).count());
    assert_eq!(leaf_triangles, s.header().leaf_triangles);
}

/// `inner` lies in `outer` (sphere and error), up to f32 rounding.
fn encloses(outer: &ErrorBound, inner: &ErrorBound) -> bool {
    let d = (glam::Vec3::from(outer.center) - glam::Vec3::from(inner.center)).length();
    d + inner.radius <= outer.radius * (1.0 + 1e-4) + 1e-6 && inner.error <= outer.error
}

/// Cut node `l` of BVH node `id` with its clusters' `cuts`: each cluster's `hi` in the node's,
/// its `lo` error no smaller than the node's, and the node's `hi` in the bound of what lies
/// below the BVH node's parent.
fn check_cut(nodes: &[NodeRecord], id: u32, l: u32, cuts: &[osw_scene::format::Cut]) {
    let n = nodes[l as usize];
    for cut in cuts {
        assert!(encloses(&n.cut_hi, &cut.hi), "cut node {l}: a cluster's hi {:?} outside {:?}", cut.hi, n.cut_hi);
        assert!(encloses(&cut.hi, &ErrorBound { error: 0.0, ..cut.lo }), "cut node {l}: a cluster's lo outside its hi: {cut:?}");
        assert!(cut.lo.error >= n.cut_lo_error && cut.lo.error <= cut.hi.error, "cut node {l}: {cut:?}");
    }
    let parent = nodes[id as usize].parent;
    if parent != NONE && nodes[parent as usize].is_bounded() {
        assert!(encloses(&nodes[parent as usize].cut_hi, &n.cut_hi), "cut node {l} outside its parent {parent}'s bound");
    }
}

// Rendering checks shared by the render and numerics tests.

/// Every mode, and prev with each HC box test.
pub const MODES: [(&str, &str); 8] = [
    ("sw", "exact"),
    ("chc", "exact"),
    ("hzb", "exact"),
    ("ovc", "exact"),
    ("prev", "exact"),
    ("prev", "pyramid"),
    ("prev", "queries"),
    ("prev", "hybrid"),
];
pub const SIZE: &str = "256x256";

/// Column `name` of a CSV file with a header row.
pub fn csv_column(file: &Path, name: &str) -> Vec<f64> {
    csv_cells(file, name).into_iter().map(|c| c.unwrap_or_else(|| panic!("{}: an empty {name}", file.display()))).collect()
}

/// Column `name` of a CSV file with a header row, `None` where a cell is empty.
pub fn csv_cells(file: &Path, name: &str) -> Vec<Option<f64>> {
    let text = std::fs::read_to_string(file).unwrap();
    let mut lines = text.lines();
    let col = lines.next().unwrap().split(',').position(|c| c == name).unwrap_or_else(|| panic!("{} has no {name}", file.display()));
    lines.map(|l| l.split(',').nth(col).unwrap()).map(|c| (!c.is_empty()).then(|| c.parse().unwrap())).collect()
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Renders with occlusion culling on every frame (`--always-cull`): the tests judge HC's.
pub fn render(scene: &Path, path: &Path, mode_hc: (&str, &str), tau: &str, out: &Path) {
    osw_ok(&render_args(scene, path, mode_hc, tau, out));
}

/// The arguments of [`render`].
pub fn render_args<'a>(scene: &'a Path, path: &'a Path, (mode, hc): (&'a str, &'a str), tau: &'a str, out: &'a Path) -> Vec<&'a str> {
    let args = ["render", "--scene", s(scene), "--path", s(path), "--mode", mode, "--hc", hc, "--tau", tau, "--size", SIZE];
    [&args[..], &["--always-cull", "--out", s(out)]].concat()
}

pub fn compare(a: &Path, b: &Path, exact: &Path, out: &Path) -> serde_json::Value {
    osw_ok(&["compare", "--a", s(a), "--b", s(b), "--exact", s(exact), "--out", s(out)]);
    serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap()
}

/// A comparison (with `--exact`) of runs that must draw the same frames (every run at tau 0
/// against vfc, or two runs of the same visible sets): no pixel drawn differently where both
/// drew the node the item buffer finds there, and every frame identical.
pub fn assert_same_frames(c: &serde_json::Value, frames: usize, label: &str) {
    assert_eq!(c["unexplained_pixels"], 0, "{label}: pixels drawn differently from the same nodes: {c}");
    assert_eq!(c["identical_frames"], frames, "{label}: frames differ: {c}");
}

/// prev, culling every frame, against vfc on `path` at `size` and tau 0, attributed through
/// the item buffer of vfc's cut: the same frames, no pixel drawn differently.
pub fn check_prev_draws_vfcs_frames(scene: &Path, path: &Path, size: &str, dir: &Path, label: &str) {
    let walk = ["--scene", s(scene), "--path", s(path), "--size", size];
    let [exact, vfc, prev] = ["exact", "vfc", "prev"].map(|n| dir.join(n));
    osw_ok(&[&["exact", "--frustum-cut"], &walk[..], &["--out", s(&exact)]].concat());
    osw_ok(&[&["render", "--mode", "vfc"], &walk[..], &["--out", s(&vfc)]].concat());
    osw_ok(&[&["render", "--mode", "prev", "--always-cull"], &walk[..], &["--out", s(&prev)]].concat());
    let c = compare(&prev, &vfc, &exact, &dir.join("cmp"));
    let frames = osw_scene::path::read(path).unwrap().len();
    assert_same_frames(&c, frames, &format!("{label}: prev against vfc"));
}

/// Renders `path` with vfc and every mode at tau 0, computes exact visibility, and checks
/// each mode against both, and vfc against itself without the small-triangle test. Returns the
/// run directory.
pub fn check_conservative(dir: &Path, scene: &Path, path: &Path, label: &str) -> PathBuf {
    let run = dir.join(label);
    let exact = run.join("exact");
    osw_ok(&["exact", "--scene", s(scene), "--path", s(path), "--size", SIZE, "--out", s(&exact)]);
    render(scene, path, ("vfc", "exact"), "0", &run.join("vfc"));
    let textures = if osw_scene::SceneFile::open(scene).unwrap().textures().is_empty() { "none" } else { "sampled" };
    let frames = osw_scene::path::read(path).unwrap().len();
    // A triangle said to cover no pixel centre makes no fragment: without that test, the same
    // frames.
    let all_but_small = run.join("vfc-all-but-small");
    let args = ["render", "--scene", s(scene), "--path", s(path), "--mode", "vfc", "--tau", "0", "--size", SIZE];
    osw_ok(&[&args[..], &["--cluster-tests", "frustum,cone,backface", "--out", s(&all_but_small)]].concat());
    let c = compare(&all_but_small, &run.join("vfc"), &exact, &run.join("cmp-small"));
    assert_eq!(c["identical_frames"], frames, "{label}: the small-triangle test changes a frame: {c}");
    for (mode, hc) in MODES {
        let name = format!("{mode}-{hc}");
        render(scene, path, (mode, hc), "0", &run.join(&name));
        let c = compare(&run.join(&name), &run.join("vfc"), &exact, &run.join(format!("cmp-{name}")));
        assert_same_frames(&c, frames, &format!("{label} {mode} against vfc"));
        assert_eq!(c["culling_a"]["false_culled_leaves_total"], 0, "{label} {mode}: false culling: {c}");
        // vfc draws every leaf in the frustum: it cannot miss one either (checks the checker).
        assert_eq!(c["culling_b"]["false_culled_leaves_total"], 0, "{label} vfc: {c}");
        let summary = std::fs::read_to_string(run.join(&name).join("summary.json")).unwrap();
        assert!(!summary.contains("NaN") && !summary.contains("null"), "{label} {mode}: {summary}");
        assert_eq!(self::summary(&run.join(&name)).textures, textures, "{label} {mode}: how textures were drawn");
    }
    run
}

/// Appends `mesh`'s positions and indices (and texture coordinates, where it has them) to the
/// GLB buffer `bin`, with a view and an accessor each; returns the primitive's attributes
/// (`{"POSITION": .., "indices": ..}`, and TEXCOORD_0).
pub fn push_mesh(
    bin: &mut Vec<u8>,
    views: &mut Vec<serde_json::Value>,
    accessors: &mut Vec<serde_json::Value>,
    mesh: &osw_scene::mesh::Mesh,
) -> serde_json::Value {
    let b = mesh.bounds();
    let k = accessors.len();
    views.push(serde_json::json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": mesh.positions.len() * 12}));
    mesh.positions.iter().flatten().for_each(|c| bin.extend(c.to_le_bytes()));
    views.push(serde_json::json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": mesh.indices.len() * 4}));
    mesh.indices.iter().for_each(|i| bin.extend(i.to_le_bytes()));
    accessors.push(serde_json::json!({"bufferView": views.len() - 2, "componentType": 5126, "count": mesh.positions.len(), "type": "VEC3",
        "min": b.min.to_array(), "max": b.max.to_array()}));
    accessors
        .push(serde_json::json!({"bufferView": views.len() - 1, "componentType": 5125, "count": mesh.indices.len(), "type": "SCALAR"}));
    let mut prim = serde_json::json!({"attributes": {"POSITION": k}, "indices": k + 1});
    if !mesh.texcoords.is_empty() {
        views.push(serde_json::json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": mesh.texcoords.len() * 8}));
        mesh.texcoords.iter().flat_map(|t| t.uv).for_each(|c| bin.extend(c.to_le_bytes()));
        accessors
            .push(serde_json::json!({"bufferView": views.len() - 1, "componentType": 5126, "count": mesh.texcoords.len(), "type": "VEC2"}));
        prim["attributes"]["TEXCOORD_0"] = serde_json::json!(k + 2);
    }
    prim
}

/// Writes a GLB of the glTF document `doc` (its one buffer's length is set) and buffer `bin`.
pub fn write_glb(path: &Path, mut doc: serde_json::Value, bin: &[u8]) {
    doc["buffers"] = serde_json::json!([{"byteLength": bin.len()}]);
    let mut text = serde_json::to_vec(&doc).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut glb = Vec::new();
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + text.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((text.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&text);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(bin);
    std::fs::write(path, glb).unwrap();
}

/// The largest fraction of differing pixels over the first `frames` frames of two runs.
pub fn differing(a: &Path, b: &Path, frames: u64) -> f64 {
    differing_by(a, b, frames, 0)
}

/// The largest fraction of pixels over the first `frames` frames of two runs whose RGB differs
/// by more than `above` levels in a channel.
pub fn differing_by(a: &Path, b: &Path, frames: u64, above: u8) -> f64 {
    use osw_render::output::{frame_path, read_png};
    let off = |p: &[u8], q: &[u8]| (0..3).any(|k| p[k].abs_diff(q[k]) > above);
    (0..frames)
        .map(|i| {
            let ((_, _, pa), (_, _, pb)) = (read_png(&frame_path(a, i)).unwrap(), read_png(&frame_path(b, i)).unwrap());
            pa.chunks_exact(4).zip(pb.chunks_exact(4)).filter(|(p, q)| off(p, q)).count() as f64 / (pa.len() / 4) as f64
        })
        .fold(0.0, f64::max)
}

/// A peer made of a blocking socket, speaking the wire as the tests choose: frames sent as
/// they are given, every byte received and sent kept (`got`, `sent`) so that a test can search
/// or replay it.
pub struct RawPeer {
    pub sock: std::net::TcpStream,
    /// Bytes received and not yet decoded.
    pub buf: Vec<u8>,
    /// Every byte received.
    pub got: Vec<u8>,
    /// Every byte sent.
    pub sent: Vec<u8>,
}

impl RawPeer {
    /// Connects to `addr`, trying again for up to 20 s while it does not listen yet.
    pub fn connect(addr: &str) -> RawPeer {
        let t = std::time::Instant::now();
        let sock = loop {
            match std::net::TcpStream::connect(addr) {
                Ok(c) => break c,
                Err(_) if t.elapsed().as_secs() < 20 => std::thread::sleep(std::time::Duration::from_millis(50)),
                Err(e) => panic!("{addr} does not listen: {e}"),
            }
        };
        RawPeer::on(sock)
    }

    /// A peer on a connected socket.
    pub fn on(sock: std::net::TcpStream) -> RawPeer {
        RawPeer { sock, buf: Vec::new(), got: Vec::new(), sent: Vec::new() }
    }

    pub fn send(&mut self, m: &osw_wire::Message) {
        let mut b = Vec::new();
        osw_wire::encode_frame(m, &mut b).unwrap();
        self.send_bytes(&b);
    }

    pub fn send_bytes(&mut self, b: &[u8]) {
        self.sent.extend_from_slice(b);
        // A peer that has closed the connection makes a write fail: not this helper's concern.
        let _ = self.sock.write_all(b);
    }

    /// The next message within `within`; None when the peer closes, sends what does not
    /// decode, or says nothing in time.
    pub fn next(&mut self, within: std::time::Duration) -> Option<osw_wire::Message> {
        let deadline = std::time::Instant::now() + within;
        loop {
            match osw_wire::decode_frame(&self.buf) {
                Ok(Some((m, used))) => {
                    self.buf.drain(..used);
                    return Some(m);
                }
                Ok(None) => {}
                Err(_) => return None,
            }
            let left = deadline.checked_duration_since(std::time::Instant::now())?;
            self.sock.set_read_timeout(Some(left.max(std::time::Duration::from_millis(1)))).unwrap();
            let mut chunk = [0u8; 1 << 16];
            match std::io::Read::read(&mut self.sock, &mut chunk) {
                Ok(0) | Err(_) => return None,
                Ok(n) => {
                    self.buf.extend_from_slice(&chunk[..n]);
                    self.got.extend_from_slice(&chunk[..n]);
                }
            }
        }
    }

    /// The handshake of osw_wire::net::handshake, as a client holding `token` says it: its
    /// challenge, its proof and `hello` (tagged), each after the peer's. Returns the peer's
    /// hello, or None where the peer stops answering.
    pub fn handshake(&mut self, hello: &osw_wire::Hello, token: Option<&osw_wire::auth::Token>) -> Option<osw_wire::Hello> {
        use osw_wire::auth::{Purpose, nonce, tag};
        use osw_wire::messages::{Challenge, Proof};
        use osw_wire::{Frame, Hello, Message};
        let wait = std::time::Duration::from_secs(20);
        let mine = nonce();
        self.send(&Message::Challenge(Challenge { version: osw_wire::limits::PROTOCOL_VERSION, nonce: mine }));
        let Message::Challenge(theirs) = self.next(wait)? else { return None };
        self.send(&Message::Proof(Proof { tag: tag(token, Purpose::Proof, &mine, &theirs.nonce, &[]) }));
        let Message::Proof(_) = self.next(wait)? else { return None };
        let untagged = Frame::new(&Message::Hello(Hello { tag: [0; 32], ..hello.clone() })).unwrap();
        self.send(&Message::Hello(Hello { tag: tag(token, Purpose::Hello, &mine, &theirs.nonce, untagged.bytes()), ..hello.clone() }));
        match self.next(wait)? {
            Message::Hello(h) => Some(h),
            _ => None,
        }
    }
}
