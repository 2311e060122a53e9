//! The peer corpus's textured models (the glTF 2.0 folder of Debian's assimp-testmodels, put in
//! models/textured/ by scripts/setup.sh: a textured box as .gltf with its files beside it,
//! embedded and binary, one with two texture coordinate sets, one whose texture is a
//! specular-glossiness material's diffuse one, KHR_texture_transform's test and a primitive
//! with only TEXCOORD_1) draw their textures: each builds with its images stored, and its
//! frame differs from the same frame drawn in the textures' mean colours (`--no-textures`) over
//! much of what the model covers. The ones osw refuses are in models/bad/ (bad_input.rs).

mod common;
use common::*;

#[test]
fn the_peer_corpus_draws_its_textures() {
    let Some(models) = setup_models("the_peer_corpus_draws_its_textures", "textured", "textured") else { return };
    assert!(models.len() >= 7, "{models:?}");
    let d = tempfile::tempdir().unwrap();
    for (k, model) in models.iter().enumerate() {
        let scene = d.path().join(format!("{k}.osw"));
        osw_ok(&["build", s(model), "-o", s(&scene)]);
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(scene.with_extension("build.json")).unwrap()).unwrap();
        assert!(report["images"].as_u64() >= Some(1) && report["texel_bytes"].as_u64() > Some(0), "{}: {report}", model.display());
        // From the front (+z, where the planes of the corpus face), a little above and aside.
        let file = osw_scene::SceneFile::open(&scene).unwrap();
        let (root, origin) = (file.node(file.root()), file.origin());
        let (lo, hi) = (glam::Vec3::from(root.bbox_min).as_dvec3() + origin, glam::Vec3::from(root.bbox_max).as_dvec3() + origin);
        let (centre, radius) = ((lo + hi) / 2.0, (hi - lo).length() / 2.0);
        let eye = centre + glam::DVec3::new(0.3, 0.4, 1.0).normalize() * radius * 2.5;
        let path = d.path().join(format!("{k}.csv"));
        osw_scene::path::write(&path, &[osw_scene::Camera::look_at(eye, centre, 50.0)]).unwrap();
        let run = |name: &str, extra: &[&str]| {
            let out = d.path().join(format!("{k}-{name}"));
            osw_ok(
                &[&["render", "--mode", "vfc", "--scene", s(&scene), "--path", s(&path), "--size", "128x128", "--out", s(&out)], extra]
                    .concat(),
            );
            out
        };
        let (sampled, means) = (run("sampled", &[]), run("means", &["--no-textures"]));
        for (out, key) in [(&sampled, "sampled"), (&means, "means")] {
            let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
            assert_eq!(summary["textures"], key, "{}: summary.json says how it drew textures", model.display());
        }
        let differ = differing_by(&sampled, &means, 1, 2);
        eprintln!("{}: {:.1}% of the pixels differ from the textures' means", model.display(), differ * 100.0);
        assert!(differ > 0.01, "{}: its texture drawn as its mean ({:.2}% of the pixels differ)", model.display(), differ * 100.0);
    }
}
