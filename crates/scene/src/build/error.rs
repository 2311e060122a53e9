//! Why a build stopped.

use crate::mesh::MeshError;
use std::path::Path;

/// Why a build stopped. The partial scene and the temporary files are removed either way.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("object {index} ({name})")]
    Mesh { index: usize, name: String, source: MeshError },
    #[error("empty scene: {0}")]
    Empty(String),
    #[error("scene too large: {0}")]
    TooLarge(String),
    #[error("{path}: {source}")]
    Write { path: String, source: std::io::Error },
    #[error("temporary file {path}: {source}")]
    Temp { path: String, source: std::io::Error },
    #[error("interrupted: the partial scene and the temporary files were removed")]
    Interrupted,
}

impl BuildError {
    pub(crate) fn temp(path: &Path, source: std::io::Error) -> BuildError {
        BuildError::Temp { path: path.display().to_string(), source }
    }
}
