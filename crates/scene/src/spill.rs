//! The build's temporary chunk file: chunks are appended as the input streams in and read back
//! by subtree once the BVH over all of them exists (see [`crate::build`]). The file lies beside
//! the output and is removed when the spill is dropped, also when the build fails or is
//! interrupted.

use crate::append::Appender;
use crate::clod::Piece;
use crate::format::Cut;
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
    normals: bool,
    texcoords: bool,
    single_sided: bool,
    /// Cuts of the piece; each triangle's cut is stored when there is more than one.
    cuts: u32,
}

impl SpillRef {
    /// Indices are u16 where every one fits (chunks of a few thousand triangles): the spill is
    /// written and read once each, so its size is time.
    fn index_bytes(&self) -> usize {
        if self.vertices <= 1 << 16 { 2 } else { 4 }
    }

    fn mesh_bytes(&self) -> usize {
        let texcoords = std::mem::size_of::<crate::texture::Texcoord>() * self.texcoords as usize;
        let attributes = 12 + 4 * self.colored as usize + 4 * self.normals as usize + texcoords + self.single_sided as usize;
        self.vertices as usize * attributes + self.indices as usize * self.index_bytes()
    }

    fn bytes(&self) -> usize {
        let cut_of = if self.cuts > 1 { self.indices as usize / 3 * 4 } else { 0 };
        self.mesh_bytes().next_multiple_of(4) + self.cuts as usize * std::mem::size_of::<Cut>() + cut_of
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

    pub fn append(&mut self, p: &Piece) -> std::io::Result<SpillRef> {
        let m = &p.mesh;
        let r = SpillRef {
            offset: self.at,
            vertices: m.positions.len() as u32,
            indices: m.indices.len() as u32,
            colored: !m.colors.is_empty(),
            normals: !m.normals.is_empty(),
            texcoords: !m.texcoords.is_empty(),
            single_sided: !m.single_sided.is_empty(),
            cuts: p.cuts.len() as u32,
        };
        let mut bytes = Vec::with_capacity(r.bytes());
        bytes.extend_from_slice(bytemuck::cast_slice(&m.positions));
        bytes.extend_from_slice(m.colors.as_flattened());
        bytes.extend_from_slice(bytemuck::cast_slice(&m.normals));
        bytes.extend_from_slice(bytemuck::cast_slice(&m.texcoords));
        if r.index_bytes() == 2 {
            bytes.extend(m.indices.iter().flat_map(|&i| (i as u16).to_le_bytes()));
        } else {
            bytes.extend_from_slice(bytemuck::cast_slice(&m.indices));
        }
        bytes.extend(m.single_sided.iter().map(|&s| u8::from(s)));
        bytes.resize(bytes.len().next_multiple_of(4), 0);
        bytes.extend_from_slice(bytemuck::cast_slice(&p.cuts));
        if p.cuts.len() > 1 {
            bytes.extend_from_slice(bytemuck::cast_slice(&p.cut_of));
        }
        debug_assert_eq!(bytes.len(), r.bytes());
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

    pub fn read(&self, r: &SpillRef) -> std::io::Result<Piece> {
        let mut buf = vec![0u8; r.bytes()];
        self.file.read_exact_at(&mut buf, r.offset)?;
        let (mesh, rest) = buf.split_at(r.mesh_bytes().next_multiple_of(4));
        let (cuts, cut_of) = rest.split_at(r.cuts as usize * std::mem::size_of::<Cut>());
        Ok(Piece {
            mesh: Self::mesh(r, &mesh[..r.mesh_bytes()]),
            cuts: bytemuck::pod_collect_to_vec(cuts),
            cut_of: if r.cuts > 1 { bytemuck::pod_collect_to_vec(cut_of) } else { Vec::new() },
        })
    }

    fn mesh(r: &SpillRef, buf: &[u8]) -> Mesh {
        let (pos, rest) = buf.split_at(r.vertices as usize * 12);
        let (colors, rest) = rest.split_at(if r.colored { r.vertices as usize * 4 } else { 0 });
        let (normals, rest) = rest.split_at(if r.normals { r.vertices as usize * 4 } else { 0 });
        let (texcoords, rest) =
            rest.split_at(if r.texcoords { r.vertices as usize * std::mem::size_of::<crate::texture::Texcoord>() } else { 0 });
        let (idx, sides) = rest.split_at(r.indices as usize * r.index_bytes());
        Mesh {
            single_sided: sides.iter().map(|&s| s != 0).collect(),
            positions: bytemuck::pod_collect_to_vec(pos),
            colors: bytemuck::pod_collect_to_vec(colors),
            normals: bytemuck::pod_collect_to_vec(normals),
            texcoords: bytemuck::pod_collect_to_vec(texcoords),
            indices: if r.index_bytes() == 2 {
                idx.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]]) as u32).collect()
            } else {
                bytemuck::pod_collect_to_vec(idx)
            },
        }
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
        let a = Mesh { positions: vec![[0.0; 3], [1.0, 2.0, 3.0], [4.0, 5.0, 6.5]], indices: vec![0, 1, 2], ..Default::default() };
        let b = Mesh {
            colors: vec![[1, 2, 3, 255]; 3],
            normals: vec![7, 8, 9],
            single_sided: vec![true, false, true],
            indices: vec![2, 1, 0, 0, 1, 2],
            ..a.clone()
        };
        let (a, mut b) = (Piece::always(a), Piece::always(b));
        b.cuts.push(Cut { hi: crate::format::ErrorBound { center: [1.0, 2.0, 3.0], radius: 4.0, error: 0.5 }, ..Cut::ALWAYS });
        b.cut_of = vec![0, 1];
        let (ra, rb) = (s.append(&a).unwrap(), s.append(&b).unwrap());
        let path = s.path().to_owned();
        let sealed = s.seal().unwrap();
        assert_eq!((sealed.read(&rb).unwrap(), sealed.read(&ra).unwrap()), (b, a));
        assert!(path.exists());
        drop(sealed);
        assert!(!path.exists());
    }
}
