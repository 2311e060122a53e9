//! On a headless host without `XDG_RUNTIME_DIR` (a server, a container, CI under another
//! shell), `osw info`, `osw render` and `osw run` print no line that says error unless
//! something failed: the Vulkan loader's device-select layer, which asks a Wayland compositor
//! for the display's GPU and printed libwayland's complaint twice a process, is left out there.

mod common;
use common::*;
use std::process::Command;

/// Runs osw without `XDG_RUNTIME_DIR`; asserts success and that stderr says no error.
fn quiet(args: &[&str]) {
    let out =
        Command::new(env!("CARGO_BIN_EXE_osw")).args(args).env_remove("XDG_RUNTIME_DIR").env_remove("NODEVICE_SELECT").output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "osw {args:?}: {err}");
    assert!(!err.to_lowercase().contains("error"), "osw {args:?} says error though nothing failed: {err}");
}

#[test]
fn a_host_without_xdg_runtime_dir_hears_no_error() {
    let d = tempfile::tempdir().unwrap();
    let scene = build_gen(d.path(), "plant", 20_000, 1);
    let path = camera_path(&scene, "walk", 3);
    quiet(&["info"]);
    let walk = ["--scene", s(&scene), "--path", s(&path), "--size", "64x64"];
    quiet(&[&["render", "--mode", "prev"], &walk[..], &["--out", s(&d.path().join("prev"))]].concat());
    quiet(&[&["run"], &walk[..], &["--out", s(&d.path().join("run"))]].concat());
}
