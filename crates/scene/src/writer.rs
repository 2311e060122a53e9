//! Writes the scene file (layout in [`crate::format`]).

use crate::format::{BLOCK_BYTES, BlockRecord, CLUSTER_BYTES, Header, MAGIC, NONE, NodeKind, NodeRecord, VERSION};
use crate::limits::BLOCK_ALIGN;
use crate::mesh::Mesh;
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;
use xxhash_rust::xxh3::{xxh3_64, xxh3_128};

/// A built scene in memory: the node table and one mesh per geometry block.
#[derive(Clone, Debug, Default)]
pub struct SceneData {
    pub origin: [f64; 3],
    pub nodes: Vec<NodeRecord>,
    pub bvh_count: u32,
    pub blocks: Vec<Mesh>,
    pub object_count: u32,
    pub leaf_count: u32,
    pub leaf_triangles: u32,
    /// Per object: its box when it is closed and wound outwards (see [`crate::cluster`]).
    pub closed_objects: Vec<Option<crate::Aabb>>,
}

fn align(x: u64) -> u64 {
    x.div_ceil(BLOCK_ALIGN) * BLOCK_ALIGN
}

/// One block's bytes, as [`crate::format`] lays them out.
struct Encoded {
    bytes: Vec<u8>,
    index_bytes: u32,
    cluster_count: u32,
}

/// The bytes of one block: positions, colours if any, then the indices in cluster order (u16
/// when every index fits, else u32), padding to 4 bytes and the clusters. `object`: the box of
/// the block's object when that is closed (see [`crate::cluster::clusterize`]).
fn block_bytes(mesh: &Mesh, object: Option<crate::Aabb>) -> Encoded {
    let (indices, clusters) = crate::cluster::clusterize(mesh, object);
    let mut bytes = Vec::with_capacity(mesh.positions.len() * 16 + indices.len() * 4 + clusters.len() * CLUSTER_BYTES as usize);
    bytes.extend_from_slice(bytemuck::cast_slice(&mesh.positions));
    bytes.extend_from_slice(mesh.colors.as_flattened());
    let index_bytes = if mesh.positions.len() <= 1 << 16 {
        bytes.extend(indices.iter().flat_map(|&i| (i as u16).to_le_bytes()));
        2
    } else {
        bytes.extend_from_slice(bytemuck::cast_slice(&indices));
        4
    };
    bytes.resize(bytes.len().next_multiple_of(4), 0);
    bytes.extend_from_slice(bytemuck::cast_slice(&clusters));
    Encoded { bytes, index_bytes, cluster_count: clusters.len() as u32 }
}

/// Hash that names the scene's content: see [`crate::format`].
pub fn content_hash(header: &Header, nodes: &[NodeRecord], blocks: &[BlockRecord]) -> [u64; 2] {
    let mut h = *header;
    h.content_hash = [0; 2];
    h.header_hash = 0;
    let mut bytes = Vec::with_capacity(256 + nodes.len() * 64 + blocks.len() * BLOCK_BYTES as usize);
    bytes.extend_from_slice(bytemuck::bytes_of(&h));
    bytes.extend_from_slice(bytemuck::cast_slice(nodes));
    bytes.extend_from_slice(bytemuck::cast_slice(blocks));
    let v = xxh3_128(&bytes);
    [v as u64, (v >> 64) as u64]
}

pub fn header_hash(header: &Header) -> u64 {
    let mut h = *header;
    h.header_hash = 0;
    xxh3_64(bytemuck::bytes_of(&h))
}

/// Writes `scene` to `path` (through a temporary file renamed into place, so that a failed
/// write never leaves a half file under the final name). Returns the file's size in bytes and
/// its content hash.
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
        .map(|(mesh, &o)| block_bytes(mesh, scene.closed_objects.get(o as usize).copied().flatten()))
        .collect();
    let mut blocks = Vec::with_capacity(encoded.len());
    let mut offset = 0u64;
    for (e, mesh) in encoded.iter().zip(&scene.blocks) {
        blocks.push(BlockRecord {
            offset,
            hash: 0,
            vertex_count: mesh.positions.len() as u32,
            index_count: mesh.indices.len() as u32,
            index_bytes: e.index_bytes,
            color_bytes: if mesh.colors.is_empty() { 0 } else { 4 },
            cluster_count: e.cluster_count,
            reserved: 0,
        });
        debug_assert_eq!(blocks.last().map(|b| b.byte_len()), Some(e.bytes.len() as u64));
        offset = align(offset + e.bytes.len() as u64);
    }
    let hashes: Vec<u64> = encoded.par_iter().map(|e| xxh3_64(&e.bytes)).collect();
    for (b, h) in blocks.iter_mut().zip(hashes) {
        b.hash = h;
    }
    let nodes_offset = std::mem::size_of::<Header>() as u64;
    let blocks_offset = nodes_offset + scene.nodes.len() as u64 * 64;
    let blob_offset = align(blocks_offset + blocks.len() as u64 * BLOCK_BYTES);
    let mut header = Header {
        magic: MAGIC,
        version: VERSION,
        header_bytes: nodes_offset as u32,
        origin: scene.origin,
        node_count: scene.nodes.len() as u32,
        bvh_count: scene.bvh_count,
        block_count: blocks.len() as u32,
        object_count: scene.object_count,
        leaf_count: scene.leaf_count,
        leaf_triangles: scene.leaf_triangles,
        nodes_offset,
        blocks_offset,
        blob_offset,
        blob_bytes: offset,
        file_bytes: blob_offset + offset,
        content_hash: [0; 2],
        header_hash: 0,
        reserved: [0; 16],
    };
    header.content_hash = content_hash(&header, &scene.nodes, &blocks);
    header.header_hash = header_hash(&header);

    let tmp = path.with_extension("osw.partial");
    let mut w = std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(&tmp)?);
    w.write_all(bytemuck::bytes_of(&header))?;
    w.write_all(bytemuck::cast_slice(&scene.nodes))?;
    w.write_all(bytemuck::cast_slice(&blocks))?;
    let mut at = blocks_offset + blocks.len() as u64 * BLOCK_BYTES;
    let zeros = [0u8; BLOCK_ALIGN as usize];
    w.write_all(&zeros[..(blob_offset - at) as usize])?;
    at = 0;
    for (e, b) in encoded.iter().zip(&blocks) {
        w.write_all(&zeros[..(b.offset - at) as usize])?;
        w.write_all(&e.bytes)?;
        at = b.offset + e.bytes.len() as u64;
    }
    w.write_all(&zeros[..(offset - at) as usize])?;
    w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
    std::fs::rename(&tmp, path)?;
    Ok((header.file_bytes, header.content_hash))
}
