//! prev and the switch draw the same frames from the same visible sets, and at tau 0 the frames
//! frustum culling draws. The 2M plant's boxes share faces with their neighbours: surfaces of
//! different nodes tie in depth on every frame of its walk, and where a run draws tied surfaces
//! in another order a pixel changes although every run drew the same nodes there. `osw compare
//! --exact` counts such pixels as drawn differently (`unexplained_pixels`), apart from the
//! pixels that culling or LOD explain.

mod common;
use common::*;
use std::path::Path;

/// An `osw path` of `frames` frames of `kind` with `seed` through `scene`, written beside it.
fn seeded_path(scene: &Path, kind: &str, frames: u32, seed: u32) -> std::path::PathBuf {
    let out = scene.with_extension(format!("{kind}-{frames}-{seed}.csv"));
    let (frames, seed) = (frames.to_string(), seed.to_string());
    osw_ok(&["path", "--scene", s(scene), "--kind", kind, "--frames", &frames, "--seed", &seed, "-o", s(&out)]);
    out
}

#[test]
fn prev_and_the_switch_draw_vfcs_frames_on_the_2m_plant_walk() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 2_000_000, 1);
    let path = seeded_path(&scene, "walk", 60, 1);
    let walk = ["--scene", s(&scene), "--path", s(&path), "--size", "1024x1024"];
    let run = |args: &[&str], name: &str| {
        let out = d.path().join(name);
        osw_ok(&[args, &walk[..], &["--out", s(&out)]].concat());
        out
    };
    // The item buffer of vfc's cut: what each pixel shows, to attribute a differing pixel.
    let exact = run(&["exact", "--frustum-cut"], "exact");
    let vfc = run(&["render", "--mode", "vfc"], "vfc");
    for tau in ["0", "1"] {
        let prev = run(&["render", "--mode", "prev", "--always-cull", "--tau", tau], &format!("prev-{tau}"));
        let switch = run(&["run", "--always-cull", "--tau", tau], &format!("switch-{tau}"));
        let pvs = |p: &Path| std::fs::read_to_string(p.join("pvs.txt")).unwrap();
        assert!(pvs(&prev) == pvs(&switch), "tau {tau}: the switch's visible sets differ from prev's");
        let c = compare(&prev, &switch, &exact, &d.path().join(format!("cmp-prev-switch-{tau}")));
        assert_same_frames(&c, 60, &format!("tau {tau}: prev against the switch"));
        if tau == "0" {
            for (name, run) in [("prev", &prev), ("switch", &switch)] {
                let c = compare(run, &vfc, &exact, &d.path().join(format!("cmp-{name}-vfc")));
                assert_same_frames(&c, 60, &format!("{name} against vfc"));
            }
        }
    }
}

/// A frame with one node's pixels painted over counts each of them as drawn differently; the
/// same frame of a run that culled the node counts none (culling explains them).
#[test]
fn a_pixel_drawn_differently_is_counted_and_one_culled_is_not() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 150_000, 3);
    let path = camera_path(&scene, "walk", 4);
    let walk = ["--scene", s(&scene), "--path", s(&path), "--size", SIZE];
    let [vfc, exact, painted] = ["vfc", "exact", "painted"].map(|n| d.path().join(n));
    osw_ok(&[&["render", "--mode", "vfc"], &walk[..], &["--out", s(&vfc)]].concat());
    osw_ok(&[&["exact"], &walk[..], &["--out", s(&exact)]].concat());
    // The node nearest at most pixels of frame 1, by the item buffer.
    let items = image::open(exact.join("items/00001.png")).unwrap().to_rgba8();
    let ids: Vec<u32> = items.pixels().map(|p| u32::from_le_bytes(p.0)).collect();
    let mut counts = std::collections::BTreeMap::<u32, u64>::new();
    ids.iter().filter(|&&i| i != 0).for_each(|&i| *counts.entry(i).or_default() += 1);
    let (&item, &pixels) = counts.iter().max_by_key(|(_, n)| **n).unwrap();
    assert!(pixels > 100, "frame 1 shows a node over {pixels} pixels");
    // Its pixels in frame 1 of a copy of vfc's run, inverted.
    std::fs::create_dir_all(painted.join("frames")).unwrap();
    for f in ["summary.json", "stats.csv", "pvs.txt", "frames/00000.png", "frames/00002.png", "frames/00003.png"] {
        std::fs::copy(vfc.join(f), painted.join(f)).unwrap();
    }
    let mut frame = image::open(vfc.join("frames/00001.png")).unwrap().to_rgba8();
    for (p, &i) in frame.pixels_mut().zip(&ids) {
        if i == item {
            p.0 = [255 - p.0[0], 255 - p.0[1], 255 - p.0[2], p.0[3]];
        }
    }
    frame.save(painted.join("frames/00001.png")).unwrap();
    let c = compare(&painted, &vfc, &exact, &d.path().join("cmp-painted"));
    assert_eq!(c["unexplained_pixels"], pixels, "{c}");
    assert_eq!(c["identical_frames"], 3, "{c}");
    // The same pixels where the painted run culled that node: culling's, not drawing's.
    let pvs = std::fs::read_to_string(vfc.join("pvs.txt")).unwrap();
    let culled: Vec<String> = pvs
        .lines()
        .enumerate()
        .map(|(f, l)| l.split(' ').filter(|id| f != 1 || id.parse::<u32>().unwrap() + 1 != item).collect::<Vec<_>>().join(" "))
        .collect();
    std::fs::write(painted.join("pvs.txt"), culled.join("\n") + "\n").unwrap();
    let c = compare(&painted, &vfc, &exact, &d.path().join("cmp-culled"));
    assert_eq!(c["unexplained_pixels"], 0, "{c}");
    assert_eq!(c["culling_a"]["false_culled_leaves_total"], 1, "{c}");
}

/// An orbit and a flyover of each generator (render.rs walks each): prev, culling every frame,
/// draws vfc's frames at tau 0 (the plant's flyover once drew a frame in 24 differently).
#[test]
fn prev_draws_vfcs_frames_on_each_generators_orbit_and_flyover() {
    let d = tempfile::tempdir().unwrap();
    for kind in ["plant", "city", "teapots", "forest", "isosurface"] {
        let scene = build_gen(d.path(), kind, 300_000, 4);
        for (path_kind, seed) in [("orbit", 2), ("flyover", 1)] {
            let path = seeded_path(&scene, path_kind, 24, seed);
            let label = format!("{kind}-{path_kind}-{seed}");
            check_prev_draws_vfcs_frames(&scene, &path, "512x512", &d.path().join(&label), &label);
        }
    }
}
