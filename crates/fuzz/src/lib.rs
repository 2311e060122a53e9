//! Fuzz targets: one function per decoder that takes untrusted bytes (protocol frames, scene
//! tables and texture table, path CSV, config, and the model readers). Each must never panic
//! on any input, and whatever it accepts must hold its invariants (checked with asserts, which
//! the fuzzer reports as crashes). `libfuzzer/` runs them under cargo fuzz
//! (`scripts/fuzz.sh`); `tests/smoke.rs` runs them on seeds and mutations in every test run.

pub mod config;
pub mod import;
pub mod path_csv;
pub mod scene_tables;
pub mod texture_table;
pub mod wire_frame;

/// A fuzz target: takes any bytes, panics only on a broken invariant.
pub type Target = fn(&[u8]);

/// Every target by name, for the smoke test.
pub const TARGETS: [(&str, Target); 8] = [
    ("wire_frame", wire_frame::run),
    ("scene_tables", scene_tables::run),
    ("texture_table", texture_table::run),
    ("path_csv", path_csv::run),
    ("config", config::run),
    ("gltf_import", import::run_gltf),
    ("obj_import", import::run_obj),
    ("ply_import", import::run_ply),
];
