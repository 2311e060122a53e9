//! Readers for scene inputs: glTF 2.0 (.gltf with external or embedded buffers, .glb), OBJ
//! and PLY. Each returns objects in their own frame with an f64 placement in the file's world
//! (see [`crate::place`]); the build cleans them up.

pub mod gltf;
mod gltf_raw;
mod images;
mod meshopt_views;
pub mod obj;
pub mod ply;

use crate::mesh::Object;
use std::path::{Path, PathBuf};

/// An input that cannot be read: the file, and what is wrong as its source.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error("{path}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}")]
    Malformed {
        path: PathBuf,
        #[source]
        source: ParseError,
    },
    #[error("{0}: unknown input format (expected .gltf, .glb, .obj or .ply)")]
    UnknownFormat(PathBuf),
}

impl ImportError {
    /// An io error reading the file at `path`.
    pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ImportError {
        move |source| ImportError::Io { path: path.to_owned(), source }
    }

    /// The contents of the file at `path` not being what they should.
    pub(crate) fn malformed(path: &Path) -> impl FnOnce(ParseError) -> ImportError {
        move |source| ImportError::Malformed { path: path.to_owned(), source }
    }
}

/// What is wrong with an input's contents, led by where in it (a mesh, a primitive, an
/// element); the error of the library that read it, if any, is its source.
#[derive(Debug, thiserror::Error)]
#[error("{what}")]
pub struct ParseError {
    what: String,
    #[source]
    source: Option<Box<dyn std::error::Error + Send + Sync>>,
}

impl ParseError {
    pub(crate) fn new(what: impl Into<String>) -> ParseError {
        ParseError { what: what.into(), source: None }
    }

    /// `what`, caused by `source`.
    pub(crate) fn caused(what: impl Into<String>, source: impl Into<Box<dyn std::error::Error + Send + Sync>>) -> ParseError {
        ParseError { what: what.into(), source: Some(source.into()) }
    }

    /// The error at `place`: "place: what".
    pub(crate) fn at(self, place: impl std::fmt::Display) -> ParseError {
        ParseError { what: format!("{place}: {}", self.what), ..self }
    }
}

/// What an importer read: the objects, the textures they sample, what it skipped with a
/// warning (the build report's notes), and what of the model it read but does not use (the
/// report's `left_out`).
#[derive(Debug, Default)]
pub struct Imported {
    pub objects: Vec<Object>,
    pub textures: crate::texture::Textures,
    pub skipped: Vec<String>,
    pub left_out: Vec<String>,
}

/// The first six of `names`, and how many more there are (a note of what was left out).
pub(crate) fn first_few(names: &[String]) -> String {
    const FEW: usize = 6;
    let shown = names[..names.len().min(FEW)].join(", ");
    match names.len().saturating_sub(FEW) {
        0 => shown,
        more => format!("{shown} and {more} more"),
    }
}

/// Reads `path` by its extension.
pub fn read(path: &Path) -> Result<Imported, ImportError> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("gltf") | Some("glb") => gltf::read(path),
        Some("obj") => obj::read(path),
        Some("ply") => Ok(Imported { objects: vec![ply::read(path)?], ..Imported::default() }),
        _ => Err(ImportError::UnknownFormat(path.to_owned())),
    }
}
