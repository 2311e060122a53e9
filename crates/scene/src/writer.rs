//! Writes the scene file (layout in [`crate::format`]) as the build goes: blocks are appended
//! to the blob as soon as they are encoded, and the node and block tables, known only at the
//! end, follow the blob. Nothing of the geometry stays in memory once written.

use crate::append::Appender;
use crate::block::{Encoded, encode};
use crate::format::{
    BlockRecord, Header, INSTANCE_BYTES, InstanceRecord, MAGIC, NONE, NodeKind, NodeRecord, VERSION, hash_tables, header_hash,
};
use crate::limits::BLOCK_ALIGN;
use crate::mesh::Mesh;
use rayon::prelude::*;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};

/// The scene-wide fields of the header that the writer does not work out itself.
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneFields {
    pub origin: [f64; 3],
    pub bvh_count: u32,
    pub object_count: u32,
    pub leaf_count: u32,
    pub leaf_triangles: u64,
}

/// A scene file being written: `<path>.partial` until [`SceneWriter::finish`] renames it into
/// place, removed if the writer is dropped before (a failed or interrupted build leaves no half
/// file under any name).
pub struct SceneWriter {
    path: PathBuf,
    partial: PathBuf,
    file: Option<Appender>,
    /// Bytes of blob written so far (a multiple of BLOCK_ALIGN).
    blob_bytes: u64,
}

const HEADER_BYTES: u64 = std::mem::size_of::<Header>() as u64;

impl SceneWriter {
    pub fn create(path: &Path) -> std::io::Result<SceneWriter> {
        let partial = path.with_extension("osw.partial");
        let mut file = Appender::new(std::fs::File::create(&partial)?);
        // The header is written last, over these zeros; the blob starts right after it.
        file.append(vec![0; HEADER_BYTES as usize])?;
        Ok(SceneWriter { path: path.to_owned(), partial, file: Some(file), blob_bytes: 0 })
    }

    /// Appends a block; returns its record with the offset filled in.
    pub fn block(&mut self, e: Encoded) -> std::io::Result<BlockRecord> {
        let record = BlockRecord { offset: self.blob_bytes, ..e.record };
        let mut bytes = e.bytes;
        bytes.resize(bytes.len().next_multiple_of(BLOCK_ALIGN as usize), 0);
        self.blob_bytes += bytes.len() as u64;
        self.file.as_mut().expect("writer open until finish").append(bytes)?;
        Ok(record)
    }

    /// The file being written (renamed into place by `finish`).
    pub fn partial_path(&self) -> &Path {
        &self.partial
    }

    /// Writes the tables and the header, and renames the file into place: the BVH nodes
    /// `bvh`, then the LOD nodes of `lods` (each naming its block by its index in `lods`) and
    /// their blocks, then the instances. Returns the file's size and its content hash.
    pub fn finish(
        mut self,
        fields: SceneFields,
        bvh: &[NodeRecord],
        lods: &[(NodeRecord, BlockRecord)],
        instances: &[InstanceRecord],
    ) -> std::io::Result<(u64, [u64; 2])> {
        let node_count = bvh.len() + lods.len();
        let blob_offset = HEADER_BYTES;
        let nodes_offset = blob_offset + self.blob_bytes;
        let blocks_offset = crate::format::blocks_offset(nodes_offset, node_count as u32).expect("offsets fit in u64");
        let instances_offset = crate::format::instances_offset(blocks_offset, lods.len() as u32).expect("offsets fit in u64");
        let file_bytes = instances_offset + instances.len() as u64 * INSTANCE_BYTES;
        let mut header = Header {
            magic: MAGIC,
            version: VERSION,
            header_bytes: HEADER_BYTES as u32,
            origin: fields.origin,
            node_count: node_count as u32,
            bvh_count: fields.bvh_count,
            block_count: lods.len() as u32,
            object_count: fields.object_count,
            leaf_count: fields.leaf_count,
            instance_count: instances.len() as u32,
            nodes_offset,
            blocks_offset,
            blob_offset,
            blob_bytes: self.blob_bytes,
            file_bytes,
            content_hash: [0; 2],
            header_hash: 0,
            instances_offset,
            leaf_triangles: fields.leaf_triangles,
            reserved: [0; 14],
        };
        header.content_hash = hash_tables(&header, |s| {
            s.update(bytemuck::cast_slice(bvh));
            lods.iter().for_each(|(n, _)| s.update(bytemuck::bytes_of(n)));
            lods.iter().for_each(|(_, b)| s.update(bytemuck::bytes_of(b)));
            s.update(bytemuck::cast_slice(instances));
        });
        header.header_hash = header_hash(&header);
        let mut file = self.file.take().expect("writer open until finish").finish()?;
        let mut tables = std::io::BufWriter::with_capacity(1 << 22, &mut file);
        tables.write_all(bytemuck::cast_slice(bvh))?;
        lods.iter().try_for_each(|(n, _)| tables.write_all(bytemuck::bytes_of(n)))?;
        tables.write_all(&[0; 8][..(blocks_offset - nodes_offset - node_count as u64 * crate::format::NODE_BYTES) as usize])?;
        lods.iter().try_for_each(|(_, b)| tables.write_all(bytemuck::bytes_of(b)))?;
        tables.write_all(bytemuck::cast_slice(instances))?;
        tables.flush()?;
        drop(tables);
        file.seek(std::io::SeekFrom::Start(0))?;
        file.write_all(bytemuck::bytes_of(&header))?;
        // No fsync: the kernel writes the pages back while the scene is already in use (a
        // 1B-triangle scene would wait a minute and a half for the disk here).
        std::fs::rename(&self.partial, &self.path)?;
        Ok((file_bytes, header.content_hash))
    }
}

impl Drop for SceneWriter {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

/// A whole scene in memory: a node table and one mesh per block, as tests and tools make them
/// by hand (the build streams instead).
#[derive(Clone, Debug, Default)]
pub struct SceneData {
    pub origin: [f64; 3],
    pub nodes: Vec<NodeRecord>,
    pub bvh_count: u32,
    pub blocks: Vec<Mesh>,
    pub object_count: u32,
    pub leaf_count: u32,
    pub leaf_triangles: u64,
    /// Per object: its box when it is closed and wound outwards (see [`crate::cluster`]).
    pub closed_objects: Vec<Option<crate::Aabb>>,
}

/// Writes `scene` to `path`. Returns the file's size in bytes and its content hash.
pub fn write_scene(path: &Path, scene: &SceneData) -> std::io::Result<(u64, [u64; 2])> {
    // Each block's object, from the LOD nodes naming it: only for a leaf's level 0, which is
    // the object's own geometry (a simplified level may have lost the object's closure; HLODs
    // have no object).
    let mut object = vec![NONE; scene.blocks.len()];
    for (id, n) in scene.nodes.iter().enumerate().filter(|(_, n)| n.kind() == NodeKind::Lod) {
        if scene.nodes[n.parent as usize].first_lod == id as u32 {
            object[n.block as usize] = n.object;
        }
    }
    let encoded: Vec<Encoded> = scene
        .blocks
        .par_iter()
        .zip(&object)
        .map(|(mesh, &o)| encode(mesh, scene.closed_objects.get(o as usize).copied().flatten()))
        .collect();
    let mut w = SceneWriter::create(path)?;
    let blocks = encoded.into_iter().map(|e| w.block(e)).collect::<std::io::Result<Vec<_>>>()?;
    // LOD node k names block k (a block two nodes share is listed for each).
    let (bvh, lods) = scene.nodes.split_at(scene.bvh_count as usize);
    let lods: Vec<(NodeRecord, BlockRecord)> =
        lods.iter().enumerate().map(|(k, n)| (NodeRecord { block: k as u32, ..*n }, blocks[n.block as usize])).collect();
    let fields = SceneFields {
        origin: scene.origin,
        bvh_count: scene.bvh_count,
        object_count: scene.object_count,
        leaf_count: scene.leaf_count,
        leaf_triangles: scene.leaf_triangles,
    };
    w.finish(fields, bvh, &lods, &[])
}
