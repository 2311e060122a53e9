//! Readers for scene inputs: glTF 2.0 (.gltf with external or embedded buffers, .glb) and PLY
//! (ASCII and binary little-endian). Each returns objects with positions in the file's world
//! frame; the build cleans them up.

pub mod gltf;
pub mod ply;

use crate::mesh::Object;
use std::path::{Path, PathBuf};

/// An input that cannot be read. The message names the file and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: {what}")]
    Malformed { path: PathBuf, what: String },
    #[error("{0}: unknown input format (expected .gltf, .glb or .ply)")]
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
        Some("ply") => {
            let mesh = ply::read(path)?;
            let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            Ok(Imported { objects: vec![Object { name, mesh }], skipped: Vec::new() })
        }
        _ => Err(ImportError::UnknownFormat(path.to_owned())),
    }
}
