//! Writes the scene file (layout in [`crate::format`]) as the build goes: blocks are appended
//! to the blob as soon as they are encoded, and the node and block tables, known only at the
//! end, follow the blob. Nothing of the geometry stays in memory once written.

use crate::append::Appender;
use crate::block::{Encoded, encode};
use crate::format::{
    BlockRecord, Header, IMAGE_BYTES, INSTANCE_BYTES, ImageRecord, InstanceRecord, MAGIC, NONE, NodeKind, NodeRecord, TEXTURE_BYTES,
    TextureRecord, VERSION, hash_tables, header_hash,
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

    /// Writes the texels, the tables and the header, and renames the file into place: the
    /// mip chains of `textures`' images, the BVH nodes `bvh`, then the LOD nodes of `lods`
    /// (each naming its block by its index in `lods`) and their blocks, the instances, and the
    /// image and texture tables. Returns the file's size and its content hash.
    pub fn finish(
        mut self,
        fields: SceneFields,
        bvh: &[NodeRecord],
        lods: &[(NodeRecord, BlockRecord)],
        instances: &[InstanceRecord],
        textures: &crate::texture::Textures,
    ) -> std::io::Result<(u64, [u64; 2])> {
        let (images, texels_bytes) = self.texels(textures)?;
        let texture_table = texture_records(textures);
        let node_count = bvh.len() + lods.len();
        let blob_offset = HEADER_BYTES;
        let nodes_offset = blob_offset + self.blob_bytes + texels_bytes;
        let blocks_offset = crate::format::blocks_offset(nodes_offset, node_count as u32).expect("offsets fit in u64");
        let instances_offset = crate::format::instances_offset(blocks_offset, lods.len() as u32).expect("offsets fit in u64");
        let images_offset = instances_offset + instances.len() as u64 * INSTANCE_BYTES;
        let file_bytes = images_offset + images.len() as u64 * IMAGE_BYTES + texture_table.len() as u64 * TEXTURE_BYTES;
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
            texels_bytes,
            images_offset,
            image_count: images.len() as u32,
            texture_count: texture_table.len() as u32,
            reserved: [0; 11],
        };
        header.content_hash = hash_tables(&header, |s| {
            s.update(bytemuck::cast_slice(bvh));
            lods.iter().for_each(|(n, _)| s.update(bytemuck::bytes_of(n)));
            lods.iter().for_each(|(_, b)| s.update(bytemuck::bytes_of(b)));
            s.update(bytemuck::cast_slice(instances));
            s.update(bytemuck::cast_slice(&images));
            s.update(bytemuck::cast_slice(&texture_table));
        });
        header.header_hash = header_hash(&header);
        let mut file = self.file.take().expect("writer open until finish").finish()?;
        let mut tables = std::io::BufWriter::with_capacity(1 << 22, &mut file);
        tables.write_all(bytemuck::cast_slice(bvh))?;
        lods.iter().try_for_each(|(n, _)| tables.write_all(bytemuck::bytes_of(n)))?;
        tables.write_all(&[0; 8][..(blocks_offset - nodes_offset - node_count as u64 * crate::format::NODE_BYTES) as usize])?;
        lods.iter().try_for_each(|(_, b)| tables.write_all(bytemuck::bytes_of(b)))?;
        tables.write_all(bytemuck::cast_slice(instances))?;
        tables.write_all(bytemuck::cast_slice(&images))?;
        tables.write_all(bytemuck::cast_slice(&texture_table))?;
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

impl SceneWriter {
    /// Appends each image's mip chain after the blob, made in parallel a few at a time;
    /// returns their records and the region's bytes. An image a cut-out uses keeps that
    /// cut-out's coverage down its chain (the first cut-out's cutoff, where several use it).
    fn texels(&mut self, textures: &crate::texture::Textures) -> std::io::Result<(Vec<ImageRecord>, u64)> {
        let cutoff = |k: usize| textures.textures.iter().find(|t| t.image as usize == k).and_then(|t| t.cutoff);
        let mut records = Vec::with_capacity(textures.images.len());
        let mut bytes_so_far = 0u64;
        let file = self.file.as_mut().expect("writer open until finish");
        for batch in (0..textures.images.len()).collect::<Vec<_>>().chunks(8) {
            let chains: Vec<Vec<crate::mip::Level>> =
                batch.par_iter().map(|&k| crate::mip::chain(&textures.images[k], cutoff(k))).collect();
            for (&k, chain) in batch.iter().zip(chains) {
                let image = &textures.images[k];
                let mut bytes: Vec<u8> = chain.iter().flat_map(|l| l.texels.as_flattened().iter().copied()).collect();
                let record = ImageRecord {
                    offset: bytes_so_far,
                    hash: xxhash_rust::xxh3::xxh3_64(&bytes),
                    width: chain[0].width,
                    height: chain[0].height,
                    levels: chain.len() as u32,
                    source_width: image.width,
                    source_height: image.height,
                    coverage_kept: cutoff(k).is_some() as u32,
                };
                bytes.resize(bytes.len().next_multiple_of(BLOCK_ALIGN as usize), 0);
                bytes_so_far += bytes.len() as u64;
                file.append(bytes)?;
                records.push(record);
            }
        }
        Ok((records, bytes_so_far))
    }
}

/// The texture table of `textures`, each with its image's mean colour.
fn texture_records(textures: &crate::texture::Textures) -> Vec<TextureRecord> {
    let means: Vec<[u8; 4]> = textures.images.iter().map(crate::texture::mean_srgb).collect();
    textures
        .textures
        .iter()
        .map(|t| TextureRecord {
            image: t.image,
            sampler: t.sampler.packed(),
            cutoff: t.cutoff.unwrap_or(-1.0),
            mean: means[t.image as usize],
        })
        .collect()
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
    pub textures: crate::texture::Textures,
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
    w.finish(fields, bvh, &lods, &[], &scene.textures)
}
