//! Files a run writes: `frames/NNNNN.png`, `osw exact`'s item buffers `items/NNNNN.png`, and id
//! lists one line per frame (`pvs.txt`: the LOD ids drawn; `exact_leaves.txt`: the exactly
//! visible leaves), read back by `osw compare`.

use osw_scene::NodeId;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A file of a run that cannot be written or read: its path, and why.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}", path.display())]
    Image {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{}: image buffer of the wrong size", path.display())]
    Size { path: PathBuf },
    #[error("{}:{line}: bad id {token:?}", path.display())]
    Id {
        path: PathBuf,
        line: usize,
        token: String,
        #[source]
        source: std::num::ParseIntError,
    },
}

impl OutputError {
    /// An io error of the file at `path`.
    pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError {
        move |source| OutputError::Io { path: path.to_path_buf(), source }
    }
}

/// The PNG of frame `i` in run directory `dir`.
pub fn frame_path(dir: &Path, i: u64) -> PathBuf {
    dir.join("frames").join(format!("{i:05}.png"))
}

/// The item buffer of frame `i` in `osw exact`'s output directory `dir`.
pub fn items_path(dir: &Path, i: u64) -> PathBuf {
    dir.join("items").join(format!("{i:05}.png"))
}

/// Writes an item buffer (a u32 a pixel, rows top first) as an RGBA8 PNG, each pixel's id in
/// its four bytes, least significant in red.
pub fn write_items(path: &Path, width: u32, height: u32, ids: &[u32]) -> Result<(), OutputError> {
    let bytes: Vec<u8> = ids.iter().flat_map(|id| id.to_le_bytes()).collect();
    write_png(path, width, height, &bytes)
}

/// Reads an item buffer [`write_items`] wrote: (width, height, ids).
pub fn read_items(path: &Path) -> Result<(u32, u32, Vec<u32>), OutputError> {
    let (w, h, bytes) = read_png(path)?;
    Ok((w, h, bytes.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()))
}

/// Writes an RGBA8 image as PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), OutputError> {
    if rgba.len() as u64 != width as u64 * height as u64 * 4 {
        return Err(OutputError::Size { path: path.to_path_buf() });
    }
    image::save_buffer(path, rgba, width, height, image::ColorType::Rgba8)
        .map_err(|source| OutputError::Image { path: path.to_path_buf(), source })
}

/// Reads a PNG as RGBA8: (width, height, pixels).
pub fn read_png(path: &Path) -> Result<(u32, u32, Vec<u8>), OutputError> {
    let img = image::open(path).map_err(|source| OutputError::Image { path: path.to_path_buf(), source })?.to_rgba8();
    Ok((img.width(), img.height(), img.into_raw()))
}

/// Appends one line of ids.
pub fn push_ids(out: &mut String, ids: &[NodeId]) {
    for (k, id) in ids.iter().enumerate() {
        if k > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{id}");
    }
    out.push('\n');
}

/// Reads an id-list file: one line per frame.
pub fn read_ids(path: &Path) -> Result<Vec<Vec<NodeId>>, OutputError> {
    let text = std::fs::read_to_string(path).map_err(OutputError::io(path))?;
    text.lines()
        .enumerate()
        .map(|(i, line)| {
            line.split_ascii_whitespace()
                .map(|t| {
                    t.parse::<NodeId>().map_err(|source| OutputError::Id {
                        path: path.to_path_buf(),
                        line: i + 1,
                        token: t.to_owned(),
                        source,
                    })
                })
                .collect()
        })
        .collect()
}
