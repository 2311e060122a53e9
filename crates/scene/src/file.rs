//! Opens a scene file by memory-mapping it (memmap2) and reads it in place.
//!
//! Opening checks the header, every size and offset, the content hash and every node and block
//! record, which touches only the header and the two tables: a process that never draws never
//! reads a page of geometry. A geometry block is checked (hash, index range) the first time it
//! is read, so a corrupted block gives an error naming the block instead of a wrong picture.

use crate::block::{Geometry, geometry_of, ranges_ok};
use crate::format::{
    BLOCK_BYTES, BlockRecord, CUT_BYTES, Header, IMAGE_BYTES, INSTANCE_BYTES, ImageRecord, InstanceRecord, MAGIC, NODE_BYTES, NONE, NodeId,
    NodeKind, NodeRecord, TEXTURE_BYTES, Tables, TextureRecord, VERSION, content_hash, header_hash,
};
use crate::instance::Placement;
use crate::limits::{BLOCK_ALIGN, MAX_BLOCK_VERTICES};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU8, Ordering};

/// What is wrong with a scene file. Every message names what was expected.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{0}: not an osw scene file (bad magic bytes)")]
    BadMagic(PathBuf),
    #[error("{path}: scene format version {found}, this build reads version {expected}; rebuild the scene with `osw build`")]
    Version { path: PathBuf, found: u32, expected: u32 },
    #[error("{path}: truncated: the header says {expected} bytes, the file has {found}")]
    Truncated { path: PathBuf, expected: u64, found: u64 },
    #[error("{path}: corrupted: {what}")]
    Corrupt { path: PathBuf, what: String },
}

/// An open, validated scene file.
pub struct SceneFile {
    path: PathBuf,
    map: memmap2::Mmap,
    header: Header,
    /// Per block: 0 = not yet checked, 1 = good, 2 = bad.
    checked: Vec<AtomicU8>,
    /// Per image, likewise.
    checked_images: Vec<AtomicU8>,
}

impl SceneFile {
    /// Maps and validates the file at `path`.
    pub fn open(path: &Path) -> Result<SceneFile, SceneError> {
        let io = |source| SceneError::Io { path: path.to_owned(), source };
        let file = std::fs::File::open(path).map_err(io)?;
        // SAFETY: the map is read-only; osw never writes a scene file in place (the writer
        // renames a finished file over the old one), so the mapped bytes do not change.
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(io)?;
        let header = validate(path, &map)?;
        let checked = (0..header.block_count).map(|_| AtomicU8::new(0)).collect();
        let checked_images = (0..header.image_count).map(|_| AtomicU8::new(0)).collect();
        Ok(SceneFile { path: path.to_owned(), map, header, checked, checked_images })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The content hash the cluster handshake compares.
    pub fn content_hash(&self) -> [u64; 2] {
        self.header.content_hash
    }

    pub fn origin(&self) -> glam::DVec3 {
        glam::DVec3::from_array(self.header.origin)
    }

    pub fn nodes(&self) -> &[NodeRecord] {
        tables_of(&self.map, &self.header).nodes
    }

    pub fn node(&self, id: NodeId) -> &NodeRecord {
        &self.nodes()[id as usize]
    }

    pub fn root(&self) -> NodeId {
        0
    }

    /// Ids below this are BVH nodes; the rest are LOD/HLOD nodes.
    pub fn bvh_count(&self) -> u32 {
        self.header.bvh_count
    }

    pub fn blocks(&self) -> &[BlockRecord] {
        tables_of(&self.map, &self.header).blocks
    }

    /// The uses of meshes stored once ([`InstanceRecord`]).
    pub fn instances(&self) -> &[InstanceRecord] {
        tables_of(&self.map, &self.header).instances
    }

    /// The images whose mip chains the file stores.
    pub fn images(&self) -> &[ImageRecord] {
        tables_of(&self.map, &self.header).images
    }

    /// The textures the blocks' texture coordinates name.
    pub fn textures(&self) -> &[TextureRecord] {
        tables_of(&self.map, &self.header).textures
    }

    /// Image `k`'s mip chain ([`ImageRecord::level`] says where each level lies), checked on
    /// first read.
    pub fn texels(&self, k: u32) -> Result<&[u8], SceneError> {
        let rec = self.images().get(k as usize).ok_or_else(|| self.corrupt(format!("image {k} of {}", self.header.image_count)))?;
        let start = (self.header.blob_offset + self.header.blob_bytes + rec.offset) as usize;
        let bytes = &self.map[start..start + rec.byte_len() as usize];
        if once_ok(&self.checked_images[k as usize], || xxhash_rust::xxh3::xxh3_64(bytes) == rec.hash) {
            Ok(bytes)
        } else {
            Err(self.corrupt(format!("image {k} fails its hash check")))
        }
    }

    fn corrupt(&self, what: String) -> SceneError {
        SceneError::Corrupt { path: self.path.clone(), what }
    }

    /// The block record of LOD node `lod` (None for other nodes).
    fn block_record(&self, lod: NodeId) -> Option<&BlockRecord> {
        let block = self.nodes().get(lod as usize).map_or(NONE, |n| n.block);
        self.blocks().get(block as usize)
    }

    /// Whether LOD node `lod`'s block stores normals (false for other nodes).
    pub fn has_normals(&self, lod: NodeId) -> bool {
        self.block_record(lod).is_some_and(|b| b.normal_bytes > 0)
    }

    /// Whether LOD node `lod`'s block stores texture coordinates (false for other nodes).
    pub fn has_texcoords(&self, lod: NodeId) -> bool {
        self.block_record(lod).is_some_and(|b| b.texcoord_bytes > 0)
    }

    /// The opaque clusters of LOD node `lod`'s block (0 for other nodes).
    pub fn opaque_clusters(&self, lod: NodeId) -> u32 {
        self.block_record(lod).map_or(0, |b| b.opaque_clusters)
    }

    /// Whether LOD node `lod` has translucent triangles (false for other nodes).
    pub fn has_translucent(&self, lod: NodeId) -> bool {
        self.block_record(lod).is_some_and(BlockRecord::has_translucent)
    }

    /// The occluding clusters of LOD node `lod`'s block: its opaque ones but the cut-outs.
    pub fn occluder_clusters(&self, lod: NodeId) -> u32 {
        self.block_record(lod).map_or(0, BlockRecord::occluder_clusters)
    }

    /// Whether LOD node `lod` has triangles that occlude nothing: translucent ones or cut-outs.
    pub fn has_see_through(&self, lod: NodeId) -> bool {
        self.block_record(lod).is_some_and(|b| b.occluder_clusters() < b.cluster_count)
    }

    /// The geometry of LOD node `lod` in the scene's frame, checked on first read; a node of an
    /// instance gets its block placed ([`crate::instance`]) at each read, so that reading a
    /// scene of ten billion placed triangles holds no more than what is read at once.
    pub fn geometry(&self, lod: NodeId) -> Result<Geometry<'_>, SceneError> {
        let g = self.stored_geometry(lod)?;
        Ok(match self.placement(lod) {
            Some(p) => p.geometry(&g),
            None => g,
        })
    }

    /// Where node `lod`'s stored geometry goes in the scene's frame: `None` unless it is an
    /// instance's node.
    pub fn placement(&self, lod: NodeId) -> Option<Placement> {
        let instance = self.node(lod).instance;
        (instance != NONE).then(|| Placement::new(self.instances()[instance as usize].affine()))
    }

    /// Where LOD node `lod`'s geometry block lies in the blob: the same place for every use of a
    /// mesh stored once (u64::MAX for a node without a block).
    pub fn block_at(&self, lod: NodeId) -> u64 {
        self.blocks().get(self.node(lod).block as usize).map_or(u64::MAX, |b| b.offset)
    }

    /// The geometry of LOD node `lod` as stored: in its mesh's own frame for an instance's node.
    pub fn stored_geometry(&self, lod: NodeId) -> Result<Geometry<'_>, SceneError> {
        let node = self
            .nodes()
            .get(lod as usize)
            .filter(|n| n.kind() == NodeKind::Lod)
            .ok_or_else(|| SceneError::Corrupt { path: self.path.clone(), what: format!("node {lod} is not a LOD node") })?;
        let b = node.block as usize;
        let rec = self.blocks()[b];
        let start = (self.header.blob_offset + rec.offset) as usize;
        let bytes = &self.map[start..start + rec.byte_len() as usize];
        let textures = self.header.texture_count;
        if !once_ok(&self.checked[b], || xxhash_rust::xxh3::xxh3_64(bytes) == rec.hash && ranges_ok(bytes, &rec, textures)) {
            return Err(self.corrupt(format!("geometry block {b} of node {lod} fails its hash or index check")));
        }
        Ok(geometry_of(bytes, &rec))
    }
}

/// Runs `check` the first time `state` is asked (0 not yet, 1 good, 2 bad); its answer.
fn once_ok(state: &AtomicU8, check: impl FnOnce() -> bool) -> bool {
    if state.load(Ordering::Acquire) == 0 {
        state.store(if check() { 1 } else { 2 }, Ordering::Release);
    }
    state.load(Ordering::Acquire) == 1
}

/// The tables of a file whose layout [`validate`] has checked.
fn tables_of<'a>(bytes: &'a [u8], h: &Header) -> Tables<'a> {
    let table = |at: u64, count: u32, size: u64| &bytes[at as usize..(at + count as u64 * size) as usize];
    let textures_offset = h.images_offset + h.image_count as u64 * IMAGE_BYTES;
    Tables {
        nodes: bytemuck::cast_slice(table(h.nodes_offset, h.node_count, NODE_BYTES)),
        blocks: bytemuck::cast_slice(table(h.blocks_offset, h.block_count, BLOCK_BYTES)),
        instances: bytemuck::cast_slice(table(h.instances_offset, h.instance_count, INSTANCE_BYTES)),
        images: bytemuck::cast_slice(table(h.images_offset, h.image_count, IMAGE_BYTES)),
        textures: bytemuck::cast_slice(table(textures_offset, h.texture_count, TEXTURE_BYTES)),
    }
}

/// Checks everything but the geometry bytes; returns the header.
pub fn validate(path: &Path, bytes: &[u8]) -> Result<Header, SceneError> {
    let corrupt = |what: String| SceneError::Corrupt { path: path.to_owned(), what };
    let hsize = std::mem::size_of::<Header>();
    if bytes.len() < 8 || bytes[..8] != MAGIC {
        return Err(SceneError::BadMagic(path.to_owned()));
    }
    if bytes.len() < hsize {
        return Err(SceneError::Truncated { path: path.to_owned(), expected: hsize as u64, found: bytes.len() as u64 });
    }
    let h: Header = bytemuck::pod_read_unaligned(&bytes[..hsize]);
    if h.version != VERSION {
        return Err(SceneError::Version { path: path.to_owned(), found: h.version, expected: VERSION });
    }
    if h.header_hash != header_hash(&h) {
        return Err(corrupt("header hash mismatch".into()));
    }
    if h.file_bytes != bytes.len() as u64 {
        return Err(SceneError::Truncated { path: path.to_owned(), expected: h.file_bytes, found: bytes.len() as u64 });
    }
    let tables_end = h.images_offset.checked_add(h.image_count as u64 * IMAGE_BYTES + h.texture_count as u64 * TEXTURE_BYTES);
    let layout_ok = h.header_bytes as usize == hsize
        && h.blob_offset == hsize as u64
        && h.blob_bytes.is_multiple_of(BLOCK_ALIGN)
        && h.texels_bytes.is_multiple_of(BLOCK_ALIGN)
        && h.blob_offset.checked_add(h.blob_bytes).and_then(|e| e.checked_add(h.texels_bytes)) == Some(h.nodes_offset)
        && crate::format::blocks_offset(h.nodes_offset, h.node_count) == Some(h.blocks_offset)
        && crate::format::instances_offset(h.blocks_offset, h.block_count) == Some(h.instances_offset)
        && h.instances_offset.checked_add(h.instance_count as u64 * INSTANCE_BYTES) == Some(h.images_offset)
        && tables_end == Some(h.file_bytes);
    if !layout_ok {
        return Err(corrupt("section offsets do not match the counts".into()));
    }
    if h.node_count == 0 || h.bvh_count == 0 || h.bvh_count > h.node_count {
        return Err(corrupt(format!("{} nodes of which {} BVH nodes", h.node_count, h.bvh_count)));
    }
    if !h.origin.iter().all(|c| c.is_finite()) {
        return Err(corrupt(format!("non-finite origin {:?}", h.origin)));
    }
    let tables = tables_of(bytes, &h);
    let (nodes, blocks, instances) = (tables.nodes, tables.blocks, tables.instances);
    if content_hash(&h, &tables) != h.content_hash {
        return Err(corrupt("content hash mismatch in the node or block table".into()));
    }
    for (i, m) in tables.images.iter().enumerate() {
        let sides_ok = [m.width, m.height].iter().all(|s| s.is_power_of_two() && *s <= crate::mip::MAX_SIDE);
        let ok = sides_ok
            && m.levels == crate::mip::level_count(m.width, m.height)
            && m.offset.is_multiple_of(BLOCK_ALIGN)
            && m.offset.checked_add(m.byte_len()).is_some_and(|e| e <= h.texels_bytes);
        if !ok {
            return Err(corrupt(format!("image {i} record is out of range: {m:?}")));
        }
    }
    for (i, t) in tables.textures.iter().enumerate() {
        if t.image >= h.image_count || crate::texture::Sampler::unpacked(t.sampler).is_none() || !t.cutoff.is_finite() {
            return Err(corrupt(format!("texture {i} record is out of range: {t:?}")));
        }
    }
    for (i, b) in blocks.iter().enumerate() {
        let ok = b.offset.is_multiple_of(BLOCK_ALIGN)
            && (b.index_bytes == 2 || b.index_bytes == 4)
            && (b.color_bytes == 0 || b.color_bytes == 4)
            && (b.normal_bytes == 0 || b.normal_bytes == 4)
            && (b.texcoord_bytes == 0 || b.texcoord_bytes as usize == std::mem::size_of::<crate::texture::Texcoord>())
            && (b.cut_bytes == 0 || b.cut_bytes == CUT_BYTES)
            && b.opaque_clusters <= b.cluster_count
            && b.cut_out_clusters <= b.opaque_clusters
            && b.index_count.is_multiple_of(3)
            && b.vertex_count <= MAX_BLOCK_VERTICES
            && b.offset.checked_add(b.byte_len()).is_some_and(|e| e <= h.blob_bytes);
        if !ok {
            return Err(corrupt(format!("block {i} record is out of range: {b:?}")));
        }
    }
    for (i, k) in instances.iter().enumerate() {
        let finite = k.linear.iter().chain(&k.translation).all(|v| v.is_finite());
        if !finite || k.object >= h.object_count {
            return Err(corrupt(format!("instance {i} has a non-finite transform or no object: {k:?}")));
        }
    }
    for (id, n) in nodes.iter().enumerate() {
        if n.instance != NONE && n.instance >= h.instance_count {
            return Err(corrupt(format!("node {id}: instance {} of {}", n.instance, h.instance_count)));
        }
        check_node(id as u32, n, nodes, &h).map_err(|what| corrupt(format!("node {id}: {what}")))?;
    }
    Ok(h)
}

fn check_node(id: u32, n: &NodeRecord, nodes: &[NodeRecord], h: &Header) -> Result<(), String> {
    let kind = NodeKind::from_u32(n.kind).ok_or_else(|| format!("unknown kind {}", n.kind))?;
    let is_bvh = id < h.bvh_count;
    if is_bvh == (kind == NodeKind::Lod) {
        return Err(format!("kind {kind:?} in the wrong id range"));
    }
    let finite = n.bbox_min.iter().chain(&n.bbox_max).all(|c| c.is_finite());
    if !finite || (0..3).any(|k| n.bbox_min[k] > n.bbox_max[k]) {
        return Err(format!("bad box {:?}..{:?}", n.bbox_min, n.bbox_max));
    }
    if !(n.error.is_finite() && n.error >= 0.0) {
        return Err(format!("bad error {}", n.error));
    }
    let in_range = |r: std::ops::Range<u64>, lo: u32, hi: u32| r.is_empty() || (r.start >= lo as u64 && r.end <= hi as u64);
    let children = n.first_child as u64..n.first_child as u64 + n.child_count as u64;
    let lods = n.first_lod as u64..n.first_lod as u64 + n.lod_count as u64;
    match kind {
        NodeKind::Lod => {
            if n.block >= h.block_count || n.parent >= h.bvh_count || n.child_count != 0 || n.lod_count != 0 {
                return Err("LOD node with bad block, owner or children".into());
            }
        }
        NodeKind::Group | NodeKind::Leaf => {
            if (id == 0) != (n.parent == NONE) || (id != 0 && n.parent >= id) {
                return Err(format!("bad parent {}", n.parent));
            }
            if !in_range(children.clone(), id + 1, h.bvh_count) || !in_range(lods.clone(), h.bvh_count, h.node_count) {
                return Err("child or LOD range out of bounds".into());
            }
            if (kind == NodeKind::Leaf) != (n.child_count == 0) || (kind == NodeKind::Leaf && n.lod_count == 0) {
                return Err("a leaf has LODs and no children; a group has children".into());
            }
            if children.clone().any(|c| nodes[c as usize].parent != id) || lods.clone().any(|l| nodes[l as usize].parent != id) {
                return Err("a child or LOD does not name this node as its parent".into());
            }
        }
    }
    Ok(())
}
