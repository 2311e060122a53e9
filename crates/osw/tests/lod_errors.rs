//! Every coarser level's stored error against the full detail it stands for, measured by `osw
//! info --check-errors` (brute force from the original geometry, not the build's step-wise
//! measure), on every real model and every generator. meshoptimizer's quadric
//! errors are blind to what moves within a plane: a race circuit's ground tiles dropped by the
//! sloppy simplifier at an error of zero, a plant's columns flattened to nothing at the error of
//! their width. Those levels were drawn at tau 1 with holes tens of pixels wide.

mod common;
use common::*;

fn check(scene: &std::path::Path, label: &str) {
    let out = osw(&["info", "--scene", s(scene), "--check-errors"]);
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().find(|l| l.starts_with("lod_errors:")).unwrap_or_else(|| panic!("{label}: no lod_errors line: {text}"));
    eprintln!("{label}: {line}");
    assert!(out.status.success(), "{label}: {line}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(line.contains(" 0 lie farther"), "{label}: {line}");
}

#[test]
fn stored_errors_bound_what_every_real_model_s_levels_drop() {
    let Some(models) = real_models("stored_errors_bound_what_every_real_model_s_levels_drop") else { return };
    let d = tempfile::tempdir().unwrap();
    for (k, model) in models.iter().enumerate() {
        let scene = d.path().join(format!("{k}.osw"));
        osw_ok(&["build", s(model), "-o", s(&scene)]);
        check(&scene, &model.display().to_string());
    }
}

#[test]
fn stored_errors_bound_what_the_generated_scenes_levels_drop() {
    let d = tempfile::tempdir().unwrap();
    let generated: [(&str, &str, &[&str]); 6] = [
        ("plant", "400000", &[]),
        ("plant", "1000000", &["--instanced"]),
        ("city", "200000", &[]),
        ("teapots", "200000", &[]),
        ("forest", "200000", &[]),
        ("isosurface", "200000", &[]),
    ];
    for (k, (generator, triangles, extra)) in generated.into_iter().enumerate() {
        let scene = d.path().join(format!("{k}.osw"));
        osw_ok(&[&["build", "--gen", generator, "--triangles", triangles, "--seed", "1", "-o", s(&scene)], extra].concat());
        check(&scene, &format!("{generator} {}", extra.join(" ")));
    }
}
