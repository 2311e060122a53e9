//! Translucent surfaces (glTF alphaMode BLEND): drawn blended over what lies behind them, in
//! the same order in every mode, and never an occluder; cut-outs (alphaMode MASK with a
//! texture): drawn where their texture's alpha passes the cutoff, and never an occluder. A red
//! box stands behind a pane of glass (or a fence whose texture is a hole where the box shows)
//! that covers it on screen, a green box behind an opaque wall. Every mode shows the red box
//! through the glass or the hole, with frames identical to frustum culling's; exact visibility counts the red box (and the pane) visible
//! and the green box hidden; no mode culls what exact visibility sees, while the occlusion
//! modes do cull the green box. A sheet turned away from the eye hides the red box when it is
//! double-sided and shows it when it is single-sided (glTF doubleSided false), in every mode
//! and in exact visibility.

mod common;
use common::*;
use osw_render::output::{frame_path, read_png};
use osw_scene::SceneFile;
use osw_scene::generators::shapes::add_box;
use osw_scene::mesh::Mesh;
use serde_json::json;
use std::path::Path;

const RED: [f64; 4] = [0.8, 0.05, 0.05, 1.0];
const GLASS: [f64; 4] = [0.1, 0.3, 0.9, 0.3];

/// How a box is drawn: its material's alpha mode and colour factor.
#[derive(Clone, Copy, PartialEq)]
enum Surface {
    Opaque([f64; 4]),
    Glass,
    /// A fence's texture on a MASK material.
    CutOut,
    /// One grey quad at the box's near z, its front facing -z (away from the paths' eye).
    Sheet {
        double_sided: bool,
    },
}

impl Surface {
    fn material(self, name: &str) -> serde_json::Value {
        match self {
            Surface::Opaque(c) => json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": c}}),
            Surface::Glass => json!({"name": name, "alphaMode": "BLEND", "pbrMetallicRoughness": {"baseColorFactor": GLASS}}),
            Surface::CutOut => json!({"name": name, "alphaMode": "MASK",
                "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.6, 0.2, 1.0], "baseColorTexture": {"index": 0}}}),
            Surface::Sheet { double_sided } => json!({"name": name, "doubleSided": double_sided,
                "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}}),
        }
    }
}

/// One node per (name, box, surface) under the root.
fn write_scene(path: &Path, boxes: &[(&str, [f32; 6], Surface)]) {
    let (mut bin, mut views, mut accessors, mut meshes, mut nodes, mut materials) = (vec![], vec![], vec![], vec![], vec![], vec![]);
    for (k, &(name, b, surface)) in boxes.iter().enumerate() {
        let mut m = Mesh::default();
        if let Surface::Sheet { .. } = surface {
            m.positions = vec![[b[0], b[1], b[2]], [b[0], b[4], b[2]], [b[3], b[4], b[2]], [b[3], b[1], b[2]]];
            m.indices = vec![0, 1, 2, 0, 2, 3];
        } else {
            add_box(&mut m, glam::Vec3::new(b[0], b[1], b[2]), glam::Vec3::new(b[3], b[4], b[5]));
        }
        if surface == Surface::CutOut {
            // The fence's texture across the box's face, v down.
            let uv = |p: &[f32; 3]| [(p[0] - b[0]) / (b[3] - b[0]), (b[4] - p[1]) / (b[4] - b[1])];
            m.texcoords = m.positions.iter().map(|p| osw_scene::texture::Texcoord { uv: uv(p), texture: 0 }).collect();
        }
        let mut prim = push_mesh(&mut bin, &mut views, &mut accessors, &m);
        prim["material"] = json!(k);
        meshes.push(json!({"primitives": [prim]}));
        nodes.push(json!({"name": name, "mesh": k}));
        materials.push(surface.material(name));
    }
    let doc = json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes, "meshes": meshes, "materials": materials, "textures": [{"source": 0}], "images": [{"uri": "fence.png"}],
        "accessors": accessors, "bufferViews": views});
    write_glb(path, doc, &bin);
    // The fence: green wire, its middle half a hole (alpha 0) wide enough for the red box.
    let fence = image::RgbaImage::from_fn(16, 16, |x, y| {
        let hole = (4..12).contains(&x) && (4..12).contains(&y);
        image::Rgba(if hole { [255, 0, 255, 0] } else { [40, 200, 40, 255] })
    });
    fence.save(path.with_file_name("fence.png")).unwrap();
}

/// Four frames from near the origin looking down -z, sliding sideways.
fn write_path(path: &Path) {
    let rows: String = (0..4).map(|i| format!("{i},{},0.1,2,0,0,0,1,50\n", i as f64 * 0.05)).collect();
    std::fs::write(path, format!("frame,px,py,pz,qx,qy,qz,qw,fovy_deg\n{rows}")).unwrap();
}

/// The leaf whose box lies within `lo..hi` (world), found from the node table.
fn leaf_in(scene: &SceneFile, lo: [f64; 3], hi: [f64; 3]) -> u32 {
    let o = scene.origin();
    (0..scene.bvh_count())
        .find(|&id| {
            let n = scene.node(id);
            n.kind() == osw_scene::format::NodeKind::Leaf
                && (0..3).all(|k| n.bbox_min[k] as f64 + o[k] >= lo[k] - 1e-3 && n.bbox_max[k] as f64 + o[k] <= hi[k] + 1e-3)
        })
        .expect("a leaf in the box")
}

/// Per frame, the ids of a run's `file` (pvs.txt, exact_leaves.txt).
fn sets(file: &Path) -> Vec<Vec<u32>> {
    std::fs::read_to_string(file).unwrap().lines().map(|l| l.split_whitespace().map(|t| t.parse().unwrap()).collect()).collect()
}

fn centre(run: &Path, frame: u64) -> [u8; 4] {
    let (w, h, px) = read_png(&frame_path(run, frame)).unwrap();
    let i = ((h / 2) * w + w / 2) as usize * 4;
    [px[i], px[i + 1], px[i + 2], px[i + 3]]
}

#[test]
fn a_box_behind_glass_is_seen_through_it_in_every_mode_and_the_glass_culls_nothing() {
    a_pane_in_front_culls_nothing(Surface::Glass);
}

/// The same behind a cut-out whose hole shows the red box: every mode draws the box through
/// it, exact visibility counts it, and no mode's depth holds the cut-out (the test fails where
/// it occludes: the red box culled).
#[test]
fn a_box_behind_a_cut_out_is_culled_in_no_mode_and_the_cut_out_culls_nothing() {
    a_pane_in_front_culls_nothing(Surface::CutOut);
}

fn a_pane_in_front_culls_nothing(pane: Surface) {
    let d = tempfile::tempdir().unwrap();
    let red = ("red", [-1.0, -1.0, -12.0, 1.0, 1.0, -10.0], Surface::Opaque(RED));
    let pane_box = ("pane", [-4.0, -4.0, -5.05, 4.0, 4.0, -5.0], pane);
    let wall = ("wall", [2.0, -3.0, -6.0, 9.0, 3.0, -5.5], Surface::Opaque([0.5, 0.5, 0.5, 1.0]));
    let green = ("green", [5.0, -1.0, -12.0, 7.0, 1.0, -10.0], Surface::Opaque([0.05, 0.8, 0.05, 1.0]));
    let path = d.path().join("path.csv");
    write_path(&path);
    let build = |name: &str, boxes: &[(&str, [f32; 6], Surface)]| {
        let (glb, scene) = (d.path().join(format!("{name}.glb")), d.path().join(format!("{name}.osw")));
        write_scene(&glb, boxes);
        osw_ok(&["build", s(&glb), "-o", s(&scene)]);
        scene
    };
    let scene = build("scene", &[red, pane_box, wall, green]);
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(scene.with_extension("build.json")).unwrap()).unwrap();
    let layer = if pane == Surface::Glass { "translucent" } else { "cut_out" };
    let counts = [format!("{layer}_triangles"), format!("{layer}_objects")].map(|k| report[k].as_u64());
    assert_eq!(counts, [Some(12), Some(1)], "{report}");
    let file = SceneFile::open(&scene).unwrap();
    let red_leaf = leaf_in(&file, [-1.0, -1.0, -12.0], [1.0, 1.0, -10.0]);
    let pane_leaf = leaf_in(&file, [-4.0, -4.0, -5.05], [4.0, 4.0, -5.0]);
    let green_leaf = leaf_in(&file, [5.0, -1.0, -12.0], [7.0, 1.0, -10.0]);

    let walk = ["--scene", s(&scene), "--path", s(&path), "--size", "96x96"];
    let exact = d.path().join("exact");
    osw_ok(&[&["exact"], &walk[..], &["--out", s(&exact)]].concat());
    for (f, leaves) in sets(&exact.join("exact_leaves.txt")).iter().enumerate() {
        assert!(
            leaves.contains(&red_leaf) && leaves.contains(&pane_leaf),
            "frame {f}: exact misses what is behind or is the pane: {leaves:?}"
        );
        assert!(!leaves.contains(&green_leaf), "frame {f}: the green box is behind an opaque wall");
    }

    // The red box shows through the glass: the centre pixel is the glass over red, not over
    // sky; and through the cut-out's hole: red, where without the box it is sky.
    let vfc = d.path().join("vfc");
    osw_ok(&[&["render", "--mode", "vfc"], &walk[..], &["--out", s(&vfc)]].concat());
    let without = build("without", &[pane_box, wall, green]);
    let sky = d.path().join("sky");
    osw_ok(&["render", "--mode", "vfc", "--scene", s(&without), "--path", s(&path), "--size", "96x96", "--out", s(&sky)]);
    let (through, over_sky) = (centre(&vfc, 0), centre(&sky, 0));
    match pane {
        Surface::Glass => {
            assert!(through[0] > through[2] && over_sky[2] > over_sky[0], "glass over red {through:?}, over sky {over_sky:?}")
        }
        _ => assert!(through[0] > 2 * through[1] && over_sky[2] > over_sky[0], "the hole over red {through:?}, over sky {over_sky:?}"),
    }

    let mut runs: Vec<(String, std::path::PathBuf)> = Vec::new();
    for mode in ["sw", "chc", "hzb", "prev", "ovc"] {
        let out = d.path().join(mode);
        osw_ok(&[&["render", "--mode", mode, "--always-cull"], &walk[..], &["--out", s(&out)]].concat());
        runs.push((mode.into(), out));
    }
    let switch = d.path().join("switch");
    osw_ok(&[&["run", "--tau", "0", "--always-cull"], &walk[..], &["--out", s(&switch)]].concat());
    runs.push(("switch".into(), switch));
    for (mode, run) in &runs {
        let c = compare(run, &vfc, &exact, &d.path().join(format!("cmp-{mode}")));
        assert_same_frames(&c, 4, &format!("{mode} against vfc"));
        assert_eq!(c["culling_a"]["false_culled_leaves_total"], 0, "{mode}: culls what exact visibility sees: {c}");
        assert_eq!(centre(run, 0), through, "{mode}");
    }
    // The occlusion tests ran against the wall and not against the pane: the green box is
    // culled in the frames after the first (HC tests against the previous frame's set).
    let prev = &runs.iter().find(|(m, _)| m == "prev").unwrap().1;
    let pvs = sets(&prev.join("pvs.txt"));
    let lod = |leaf: u32| file.node(leaf).first_lod;
    assert!(pvs[1..].iter().all(|p| p.contains(&lod(red_leaf)) && !p.contains(&lod(green_leaf))), "prev's PVS: {pvs:?}");
}

/// Every mode and exact visibility against the same sheet turned away from the eye in front of
/// the red box: single-sided, it is neither drawn nor an occluder, so the red box shows; double
/// sided, it hides the box. Frames equal vfc's, and no mode culls what exact visibility sees.
#[test]
fn a_sheet_seen_from_behind_hides_only_when_double_sided() {
    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("path.csv");
    write_path(&path);
    for double_sided in [false, true] {
        let red = ("red", [-1.0, -1.0, -12.0, 1.0, 1.0, -10.0], Surface::Opaque(RED));
        let sheet = ("sheet", [-4.0, -4.0, -5.0, 4.0, 4.0, -5.0], Surface::Sheet { double_sided });
        let (glb, scene) = (d.path().join(format!("{double_sided}.glb")), d.path().join(format!("{double_sided}.osw")));
        write_scene(&glb, &[red, sheet]);
        osw_ok(&["build", s(&glb), "-o", s(&scene)]);
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(scene.with_extension("build.json")).unwrap()).unwrap();
        assert_eq!(report["single_sided_triangles"].as_u64(), Some(if double_sided { 12 } else { 14 }), "{report}");
        let file = SceneFile::open(&scene).unwrap();
        let red_leaf = leaf_in(&file, [-1.0, -1.0, -12.0], [1.0, 1.0, -10.0]);
        let sheet_leaf = leaf_in(&file, [-4.0, -4.0, -5.0], [4.0, 4.0, -5.0]);
        let walk = ["--scene", s(&scene), "--path", s(&path), "--size", "96x96"];
        let dir = d.path().join(format!("{double_sided}"));
        let exact = dir.join("exact");
        osw_ok(&[&["exact"], &walk[..], &["--out", s(&exact)]].concat());
        for (f, leaves) in sets(&exact.join("exact_leaves.txt")).iter().enumerate() {
            let want = if double_sided { (false, true) } else { (true, false) };
            assert_eq!(
                (leaves.contains(&red_leaf), leaves.contains(&sheet_leaf)),
                want,
                "frame {f}, double-sided {double_sided}: {leaves:?}"
            );
        }
        let vfc = dir.join("vfc");
        osw_ok(&[&["render", "--mode", "vfc"], &walk[..], &["--out", s(&vfc)]].concat());
        let c = centre(&vfc, 0);
        assert_eq!(c[0] > c[1] + 50, !double_sided, "the centre {c:?}: red through a single-sided sheet, grey on a double-sided one");
        let mut runs = Vec::new();
        for mode in ["sw", "chc", "hzb", "prev", "ovc"] {
            let out = dir.join(mode);
            osw_ok(&[&["render", "--mode", mode, "--always-cull"], &walk[..], &["--out", s(&out)]].concat());
            runs.push((mode, out));
        }
        let switch = dir.join("switch");
        osw_ok(&[&["run", "--tau", "0", "--always-cull"], &walk[..], &["--out", s(&switch)]].concat());
        runs.push(("switch", switch));
        for (mode, run) in &runs {
            let cmp = compare(run, &vfc, &exact, &dir.join(format!("cmp-{mode}")));
            assert_same_frames(&cmp, 4, &format!("{mode} against vfc, double-sided {double_sided}"));
            assert_eq!(cmp["culling_a"]["false_culled_leaves_total"], 0, "{mode}: culls what exact visibility sees: {cmp}");
        }
    }
}
