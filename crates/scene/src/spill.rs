//! The build's temporary chunk file: chunks are appended as the input streams in and read back
//! by subtree once the BVH over all of them exists (see [`crate::build`]). The file lies beside
//! the output and is removed when the spill is dropped, also when the build fails or is
//! interrupted.

use crate::append::Appender;
use crate::mesh::Mesh;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

/// Where a chunk lies in the spill file.
#[derive(Clone, Copy, Debug)]
pub struct SpillRef {
    pub(crate) offset: u64,
    vertices: u32,
    indices: u32,
    colored: bool,
}

impl SpillRef {
    /// Indices are u16 where every one fits (chunks of a few thousand triangles): the spill is
    /// written and read once each, so its size is time.
    fn index_bytes(&self) -> usize {
        if self.vertices <= 1 << 16 { 2 } else { 4 }
    }

    fn bytes(&self) -> usize {
        self.vertices as usize * (12 + if self.colored { 4 } else { 0 }) + self.indices as usize * self.index_bytes()
    }
}

/// A spill file being written.
pub struct Spill {
    path: PathBuf,
    file: Option<Appender>,
    at: u64,
}

impl Spill {
    pub fn create(beside: &Path) -> std::io::Result<Spill> {
        let path = beside.with_extension("osw.spill");
        let file = std::fs::OpenOptions::new().read(true).write(true).create(true).truncate(true).open(&path)?;
        Ok(Spill { path, file: Some(Appender::new(file)), at: 0 })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes appended so far.
    pub fn bytes(&self) -> u64 {
        self.at
    }

    pub fn append(&mut self, m: &Mesh) -> std::io::Result<SpillRef> {
        let r = SpillRef {
            offset: self.at,
            vertices: m.positions.len() as u32,
            indices: m.indices.len() as u32,
            colored: !m.colors.is_empty(),
        };
        let mut bytes = Vec::with_capacity(r.bytes());
        bytes.extend_from_slice(bytemuck::cast_slice(&m.positions));
        bytes.extend_from_slice(m.colors.as_flattened());
        if r.index_bytes() == 2 {
            bytes.extend(m.indices.iter().flat_map(|&i| (i as u16).to_le_bytes()));
        } else {
            bytes.extend_from_slice(bytemuck::cast_slice(&m.indices));
        }
        self.file.as_mut().expect("open until sealed").append(bytes)?;
        self.at += r.bytes() as u64;
        Ok(r)
    }

    /// Ends writing; the chunks can be read from any thread.
    pub fn seal(mut self) -> std::io::Result<Sealed> {
        let file = self.file.take().expect("open until sealed").finish()?;
        Ok(Sealed { path: std::mem::take(&mut self.path), file, bytes: self.at })
    }
}

impl Drop for Spill {
    fn drop(&mut self) {
        if !self.path.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// A spill file whose chunks are all written.
pub struct Sealed {
    path: PathBuf,
    file: std::fs::File,
    bytes: u64,
}

impl Sealed {
    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    pub fn read(&self, r: &SpillRef) -> std::io::Result<Mesh> {
        let mut buf = vec![0u8; r.bytes()];
        self.file.read_exact_at(&mut buf, r.offset)?;
        let (pos, rest) = buf.split_at(r.vertices as usize * 12);
        let (colors, idx) = rest.split_at(if r.colored { r.vertices as usize * 4 } else { 0 });
        Ok(Mesh {
            positions: bytemuck::pod_collect_to_vec(pos),
            colors: bytemuck::pod_collect_to_vec(colors),
            indices: if r.index_bytes() == 2 {
                idx.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]]) as u32).collect()
            } else {
                bytemuck::pod_collect_to_vec(idx)
            },
        })
    }
}

impl Drop for Sealed {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_come_back_as_written_and_the_file_goes() {
        let d = tempfile::tempdir().unwrap();
        let mut s = Spill::create(&d.path().join("s.osw")).unwrap();
        let a = Mesh { positions: vec![[0.0; 3], [1.0, 2.0, 3.0], [4.0, 5.0, 6.5]], indices: vec![0, 1, 2], colors: Vec::new() };
        let b = Mesh { colors: vec![[1, 2, 3, 255]; 3], indices: vec![2, 1, 0, 0, 1, 2], ..a.clone() };
        let (ra, rb) = (s.append(&a).unwrap(), s.append(&b).unwrap());
        let path = s.path().to_owned();
        let sealed = s.seal().unwrap();
        assert_eq!((sealed.read(&rb).unwrap(), sealed.read(&ra).unwrap()), (b, a));
        assert!(path.exists());
        drop(sealed);
        assert!(!path.exists());
    }
}
