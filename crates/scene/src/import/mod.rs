//! Readers for scene inputs: glTF 2.0 (.gltf with external or embedded buffers, .glb), OBJ
//! and PLY. Each returns objects in their own frame with an f64 placement in the file's world
//! (see [`crate::place`]); the build cleans them up.

pub mod gltf;
mod gltf_raw;
mod meshopt_views;
pub mod obj;
pub mod ply;

use crate::mesh::Object;
use std::path::{Path, PathBuf};

/// An input that cannot be read. The message names the file and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// (Not a `source`: the message already says it, and once is enough.)
    #[error("{path}: {error}")]
    Io { path: PathBuf, error: std::io::Error },
    #[error("{path}: {what}")]
    Malformed { path: PathBuf, what: String },
    #[error("{0}: unknown input format (expected .gltf, .glb, .obj or .ply)")]
    UnknownFormat(PathBuf),
}

/// What an importer skipped with a warning (the build report lists these).
#[derive(Debug, Default)]
pub struct Imported {
    pub objects: Vec<Object>,
    pub skipped: Vec<String>,
}

/// Reads `path` by its extension.
pub fn read(path: &Path) -> Result<Imported, ImportError> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("gltf") | Some("glb") => gltf::read(path),
        Some("obj") => obj::read(path),
        Some("ply") => Ok(Imported { objects: vec![ply::read(path)?], skipped: Vec::new() }),
        _ => Err(ImportError::UnknownFormat(path.to_owned())),
    }
}
