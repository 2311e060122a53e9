//! The scene file format, version 10: one file that the three processes of the cluster map into
//! memory and read in place (occlusion switch, sec. 3.5: every process holds the same scene and refers
//! to nodes by the same integer id).
//!
//! ```text
//! offset 0              Header (256 bytes)
//! header.blob_offset    geometry blocks (256), each BLOCK_ALIGN-aligned and padded to it:
//!                       [[f32; 3]; vertex_count], [[u8; 4]; vertex_count] when the
//!                       block has colours, [u32; vertex_count] octahedral normals when
//!                       it has normals, [Texcoord; vertex_count] when it is textured,
//!                       [u16 or u32; index_count] in cluster order,
//!                       padding to 4 bytes, [ClusterRecord; cluster_count], then in a
//!                       cluster hierarchy's block [Cut; cluster_count]
//! blob end              texels: each image's mip chain, RGBA8 sRGB, finest level first,
//!                       each chain BLOCK_ALIGN-aligned (header.texels_bytes in all)
//! header.nodes_offset   [NodeRecord; node_count]       104 bytes each, right after the texels
//! header.blocks_offset  [BlockRecord; block_count]     56 bytes each, 8-aligned
//! header.instances_offset [InstanceRecord; instance_count] 104 bytes each
//! header.images_offset  [ImageRecord; image_count]     40 bytes each
//!                       [TextureRecord; texture_count] 16 bytes each, to the end
//! ```
//! The tables follow the blob because the build streams: blocks are written as each part of the
//! model is built, and the tables are complete only at the end (see [`crate::build`]). Blocks
//! lie in the blob in the order they were built (a subtree's blocks together), not in id order.
//! All integers little-endian. Node ids are dense: ids `0..bvh_count` are BVH nodes in
//! breadth-first order (root = 0), ids `bvh_count..node_count` are LOD and HLOD nodes, each its
//! own id as in occlusion switch sec. 4.1; a BVH node's LODs are contiguous, finest first.
//!
//! A mesh that the model uses several times (a catalogue part) is stored once, in its own
//! frame: the LOD nodes of each use name the same blocks and an [`InstanceRecord`] that places
//! them (see [`crate::instance`]). Every use keeps its own node ids, so the wire, the visible
//! sets and the hierarchy's tests do not know instances exist.
//!
//! Hashes (xxh3): `header_hash` covers the header with that field zeroed; `content_hash` covers
//! the header's scene fields, the node table and the block table (which holds a hash of every
//! block), so it names the whole content while opening reads only the tables. A block's own
//! hash is checked when the block is first read.

use bytemuck::{Pod, Zeroable};

/// Index of a node in the node table: a BVH node or a LOD/HLOD node.
pub type NodeId = u32;

/// Marks "no node" / "no block" in u32 fields.
pub const NONE: u32 = u32::MAX;

pub const MAGIC: [u8; 8] = *b"OSWSCENE";
/// 2: geometry blocks may carry the model's colours (version 1 had none). 3: each block's
/// triangles are grouped into clusters with bounds and normal cones (see [`ClusterRecord`]).
/// 4: the tables follow the blob (an out-of-core build writes them last). 5: a block's
/// translucent triangles are its last clusters ([`BlockRecord::opaque_clusters`]). 6: the
/// cluster hierarchy: nodes and clusters carry [`Cut`] bounds (see [`crate::clod`]). 7: a
/// mesh used several times is stored once: nodes name an [`InstanceRecord`]; triangle counts
/// of subtrees and the scene are u64. 8: a cluster's [`Cut`] is stored only in a cluster
/// hierarchy's blocks ([`BlockRecord::cut_bytes`]): a static LOD's clusters are drawn at every
/// tau, and a chains scene stored 40 bytes a cluster to say so. Later in 8, a block's padding
/// became [`BlockRecord::cut_out_clusters`]: 0 in files written before, which reads as what
/// they meant (no cut-outs), and a reader from before takes cut-outs for opaque triangles.
/// 9: a block may store a normal per vertex ([`BlockRecord::normal_bytes`]), after the
/// colours: the depth passes read positions alone, and a scene built flat stores none; a
/// cluster of single-sided triangles has an empty closed box ([`ClusterRecord::single_sided`]).
/// 10: textures: a block may store a [`crate::texture::Texcoord`] per vertex
/// ([`BlockRecord::texcoord_bytes`]), and the file the images' mip chains and a table of
/// textures ([`ImageRecord`], [`TextureRecord`]) that only the display reads.
pub const VERSION: u32 = 10;

/// The fixed-size file header.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct Header {
    pub magic: [u8; 8],
    pub version: u32,
    pub header_bytes: u32,
    /// World position of local coordinate 0: world = origin + local (f64 so that a scene far
    /// from the origin keeps f32 precision in its local coordinates).
    pub origin: [f64; 3],
    pub node_count: u32,
    /// Ids below this are BVH nodes, ids from it on are LOD/HLOD nodes.
    pub bvh_count: u32,
    pub block_count: u32,
    pub object_count: u32,
    pub leaf_count: u32,
    pub instance_count: u32,
    pub nodes_offset: u64,
    pub blocks_offset: u64,
    pub blob_offset: u64,
    pub blob_bytes: u64,
    pub file_bytes: u64,
    pub content_hash: [u64; 2],
    pub header_hash: u64,
    pub instances_offset: u64,
    /// Triangles of the full-detail scene (all level-0 LODs, each use of a mesh counted).
    pub leaf_triangles: u64,
    /// Bytes of the texel region, between the blob and the node table.
    pub texels_bytes: u64,
    pub images_offset: u64,
    pub image_count: u32,
    pub texture_count: u32,
    pub reserved: [u64; 11],
}

/// A content hash as the reports and the handshake print it: 32 hex digits, high word first.
pub fn hash_hex(hash: [u64; 2]) -> String {
    format!("{:016x}{:016x}", hash[1], hash[0])
}

/// What a node is. BVH nodes are `Group` (interior) or `Leaf` (one chunk); `Lod` nodes hold
/// geometry: a level of a leaf's chain or a group's HLOD.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    Group = 0,
    Leaf = 1,
    Lod = 2,
}

impl NodeKind {
    pub fn from_u32(v: u32) -> Option<NodeKind> {
        match v {
            0 => Some(NodeKind::Group),
            1 => Some(NodeKind::Leaf),
            2 => Some(NodeKind::Lod),
            _ => None,
        }
    }
}

/// A conservative error and where it lies: `error` (world units) on geometry inside the sphere
/// at `center` with `radius` (Yoon 2003 sec. 6.3.1 projects an error from the nearest point
/// of its bound; see [`crate::error_metric`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct ErrorBound {
    pub center: [f32; 3],
    pub radius: f32,
    pub error: f32,
}

/// Where a triangle of a cluster hierarchy is drawn (see [`crate::clod`]): while the error of
/// the group it was made from (`lo`) meets tau and the error of the coarser triangles made
/// from its own group (`hi`) does not. A triangle of the original mesh has `lo.error` 0; one of
/// a group never simplified further has `hi.error` infinite.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct Cut {
    pub hi: ErrorBound,
    pub lo: ErrorBound,
}

impl Cut {
    /// Drawn at every tau: the clusters of static LODs and HLODs.
    pub const ALWAYS: Cut = Cut {
        hi: ErrorBound { center: [0.0; 3], radius: 0.0, error: f32::INFINITY },
        lo: ErrorBound { center: [0.0; 3], radius: 0.0, error: 0.0 },
    };
}

/// [`NodeRecord::flags`]: a LOD node whose block is a BVH node's part of the cluster hierarchy,
/// drawn cluster by cluster where the cut takes them ([`NodeRecord::cut_hi`] bounds them).
pub const FLAG_CUT: u32 = 1;
/// [`NodeRecord::flags`]: a BVH node whose subtree holds only cluster hierarchies (no static
/// chain), so that [`NodeRecord::cut_hi`] bounds every cut cluster below it.
pub const FLAG_BOUNDED: u32 = 2;

/// One node: 104 bytes.
///
/// For a BVH node, `error` is the object-space error of its finest representation (0 for a leaf,
/// whose level 0 is the original; the HLOD's error for a group with an HLOD; for a group
/// without one, the largest of its children's, so errors never decrease going up). For a LOD
/// node it is the distance (world units, approximately Hausdorff) between that level and the
/// original geometry.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct NodeRecord {
    pub bbox_min: [f32; 3],
    pub kind: u32,
    pub bbox_max: [f32; 3],
    pub error: f32,
    /// Triangles: of the block for a LOD node, of the full-detail subtree for a BVH node (each
    /// use of a mesh counted: more than 2^32 in a large instanced scene).
    pub triangles: u64,
    /// BVH parent for BVH nodes (NONE for the root), owning BVH node for LOD nodes.
    pub parent: u32,
    /// BVH children `first_child..first_child + child_count` (groups only).
    pub first_child: u32,
    pub child_count: u32,
    /// LOD nodes `first_lod..first_lod + lod_count`, finest first (BVH nodes only).
    pub first_lod: u32,
    pub lod_count: u32,
    /// Geometry block of a LOD node (NONE for BVH nodes).
    pub block: u32,
    /// Object the geometry came from (leaves and their LODs; NONE for groups and HLODs).
    pub object: u32,
    /// [`FLAG_CUT`], [`FLAG_BOUNDED`].
    pub flags: u32,
    /// A cut node: encloses its clusters' `hi` bounds, with the largest error (each cluster's
    /// `hi` sphere encloses its `lo` sphere, so this one encloses those too). A BVH node with
    /// [`FLAG_BOUNDED`]: encloses the `cut_hi` of the cut nodes strictly below it. Zero otherwise.
    pub cut_hi: ErrorBound,
    /// A cut node: the smallest error of its clusters' `lo` bounds. Zero otherwise.
    pub cut_lo_error: f32,
    /// The use of a stored-once mesh this node belongs to ([`InstanceRecord`]), or NONE. A LOD
    /// node's block is then in the mesh's own frame, its box and error in the scene's.
    pub instance: u32,
    pub _pad: u32,
}

impl NodeRecord {
    pub fn kind(&self) -> NodeKind {
        // Validated when the file is opened.
        NodeKind::from_u32(self.kind).unwrap_or(NodeKind::Group)
    }

    pub fn children(&self) -> std::ops::Range<u32> {
        self.first_child..self.first_child + self.child_count
    }

    pub fn lods(&self) -> std::ops::Range<u32> {
        self.first_lod..self.first_lod + self.lod_count
    }

    pub fn aabb(&self) -> crate::Aabb {
        crate::Aabb::new(self.bbox_min.into(), self.bbox_max.into())
    }

    pub fn is_cut(&self) -> bool {
        self.flags & FLAG_CUT != 0
    }

    pub fn is_bounded(&self) -> bool {
        self.flags & FLAG_BOUNDED != 0
    }
}

/// Where one geometry block lies in the blob: 56 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct BlockRecord {
    /// Offset from the start of the blob; a multiple of BLOCK_ALIGN.
    pub offset: u64,
    /// xxh3-64 of the block's bytes.
    pub hash: u64,
    pub vertex_count: u32,
    pub index_count: u32,
    /// 2 or 4.
    pub index_bytes: u32,
    /// 4 when the block stores an RGBA8 colour per vertex (see [`crate::mesh::Mesh::colors`]),
    /// else 0.
    pub color_bytes: u32,
    /// Clusters after the indices; together they hold every triangle once.
    pub cluster_count: u32,
    /// Clusters `0..opaque_clusters` hold the opaque triangles, the rest the translucent ones
    /// (see [`crate::mesh::is_translucent`]): drawn blended after everything opaque, never into
    /// OR's depth, so that a translucent surface occludes nothing.
    pub opaque_clusters: u32,
    /// 40 when a [`Cut`] per cluster follows the clusters (a cluster hierarchy's block), else 0:
    /// every cluster is drawn at every tau ([`Cut::ALWAYS`]).
    pub cut_bytes: u32,
    /// The last of the opaque clusters that hold cut-outs ([`crate::mesh::CUT_OUT`]): drawn
    /// opaque, never into an occluder pass's depth.
    pub cut_out_clusters: u32,
    /// 4 when the block stores a normal per vertex (octahedral, see [`crate::normal`]), else 0:
    /// shaded flat.
    pub normal_bytes: u32,
    /// 12 when the block stores a [`crate::texture::Texcoord`] per vertex, else 0.
    pub texcoord_bytes: u32,
}

impl BlockRecord {
    /// Bytes of a vertex's attributes: position, colour, normal and texture coordinates.
    pub fn vertex_bytes(&self) -> u64 {
        12 + self.color_bytes as u64 + self.normal_bytes as u64 + self.texcoord_bytes as u64
    }

    /// Bytes of the vertices and indices (every vertex stream is a multiple of 4 bytes, so
    /// indices start 4-byte aligned), rounded up to 4.
    pub fn clusters_at(&self) -> u64 {
        (self.vertex_count as u64 * self.vertex_bytes() + self.index_count as u64 * self.index_bytes as u64).next_multiple_of(4)
    }

    /// Bytes of the whole block.
    pub fn byte_len(&self) -> u64 {
        self.clusters_at() + self.cluster_count as u64 * (CLUSTER_BYTES + self.cut_bytes as u64)
    }

    pub fn has_translucent(&self) -> bool {
        self.opaque_clusters < self.cluster_count
    }

    /// Clusters that occlude: `0..occluder_clusters()`, the opaque ones but the cut-outs.
    pub fn occluder_clusters(&self) -> u32 {
        self.opaque_clusters.saturating_sub(self.cut_out_clusters)
    }
}

/// A run of at most [`crate::cluster::MAX_TRIANGLES`] triangles of one block, close together
/// and facing alike, that a pass culls as a unit: 100 bytes (where the cut draws it, in a
/// cluster hierarchy, follows the block's clusters: [`BlockRecord::cut_bytes`]).
///
/// The cone is meshopt's: every triangle of the cluster faces away from an eye at `e` when
/// `dot(normalize(apex - e), axis) >= cutoff`, or (looser near the cluster, but without the
/// apex's precision limits far away) when `dot(c - e, axis) >= cutoff * |c - e| + radius`
/// with `c` the centre. A back face is hidden only while the eye is outside the closed part it
/// belongs to: `closed_min..closed_max` bounds the closed parts of the cluster's triangles (see
/// [`crate::cluster`]). A cluster with a triangle of an open part stores a cutoff of
/// [`crate::cluster::NO_CONE`], which no eye passes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct ClusterRecord {
    /// Bounding sphere, block-local (the scene's local frame).
    pub center: [f32; 3],
    pub radius: f32,
    pub cone_apex: [f32; 3],
    pub cone_axis: [f32; 3],
    pub cone_cutoff: f32,
    /// Indices `first_index..first_index + index_count` of the block.
    pub first_index: u32,
    pub index_count: u32,
    /// Bounding box, for occlusion tests (tighter than the sphere on flat clusters).
    pub bbox_min: [f32; 3],
    pub bbox_max: [f32; 3],
    pub closed_min: [f32; 3],
    pub closed_max: [f32; 3],
}

impl ClusterRecord {
    /// A cluster of single-sided triangles (glTF `doubleSided` false) stores an empty closed
    /// box (min above max): its back faces are never drawn, so the eye is outside it
    /// everywhere, and every pass drops them whatever its tests (see `osw_cull::cluster`).
    pub fn single_sided(&self) -> bool {
        self.closed_min[0] > self.closed_max[0]
    }

    pub fn aabb(&self) -> crate::Aabb {
        crate::Aabb::new(self.bbox_min.into(), self.bbox_max.into())
    }
}

/// One use of a mesh stored once: its LOD nodes' blocks are drawn at
/// `linear · p + translation` (scene-local, column-major, f64 so that a use far out places its
/// vertices as exactly as an expanded copy; see [`crate::place`]): 104 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct InstanceRecord {
    pub linear: [f64; 9],
    pub translation: [f64; 3],
    /// The input's mesh (its index among the stored-once meshes).
    pub prototype: u32,
    /// The object this use is.
    pub object: u32,
}

impl InstanceRecord {
    pub fn affine(&self) -> glam::DAffine3 {
        glam::DAffine3 { matrix3: glam::DMat3::from_cols_array(&self.linear), translation: glam::DVec3::from_array(self.translation) }
    }
}

/// One image's mip chain in the texel region ([`crate::mip`]): 40 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct ImageRecord {
    /// From the start of the texel region; a multiple of BLOCK_ALIGN.
    pub offset: u64,
    /// xxh3-64 of the chain's bytes.
    pub hash: u64,
    /// Level 0, powers of two; the chain halves both sides down to 1x1.
    pub width: u32,
    pub height: u32,
    pub levels: u32,
    /// The image's own size, before level 0 was made of it.
    pub source_width: u32,
    pub source_height: u32,
    /// 1 when the chain's alpha keeps a cut-out's coverage ([`crate::mip`]), else 0.
    pub coverage_kept: u32,
}

impl ImageRecord {
    pub fn byte_len(&self) -> u64 {
        crate::mip::chain_bytes(self.width, self.height)
    }

    /// Level `k`'s size and where it starts within the chain.
    pub fn level(&self, k: u32) -> (u32, u32, u64) {
        let at =
            crate::mip::chain_bytes(self.width, self.height) - crate::mip::chain_bytes((self.width >> k).max(1), (self.height >> k).max(1));
        ((self.width >> k).max(1), (self.height >> k).max(1), at)
    }
}

/// A texture as a material uses it: 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct TextureRecord {
    pub image: u32,
    /// [`crate::texture::Sampler::packed`].
    pub sampler: u32,
    /// A cut-out's alpha cutoff, or a negative value for a surface that is not one.
    pub cutoff: f32,
    /// The image's mean colour (sRGB, alpha its coverage): what a display that samples no
    /// textures draws.
    pub mean: [u8; 4],
}

pub const NODE_BYTES: u64 = std::mem::size_of::<NodeRecord>() as u64;
pub const IMAGE_BYTES: u64 = std::mem::size_of::<ImageRecord>() as u64;
pub const TEXTURE_BYTES: u64 = std::mem::size_of::<TextureRecord>() as u64;
pub const BLOCK_BYTES: u64 = std::mem::size_of::<BlockRecord>() as u64;

/// Where the block table starts after `node_count` nodes at `nodes_offset`: padded to 8 bytes,
/// the alignment of its u64 fields.
pub fn blocks_offset(nodes_offset: u64, node_count: u32) -> Option<u64> {
    Some(nodes_offset.checked_add(node_count as u64 * NODE_BYTES)?.next_multiple_of(8))
}
pub const CLUSTER_BYTES: u64 = std::mem::size_of::<ClusterRecord>() as u64;
pub const CUT_BYTES: u32 = std::mem::size_of::<Cut>() as u32;
pub const INSTANCE_BYTES: u64 = std::mem::size_of::<InstanceRecord>() as u64;

/// Where the instance table starts after `block_count` blocks at `blocks_offset` (8-aligned
/// already: blocks are 56 bytes).
pub fn instances_offset(blocks_offset: u64, block_count: u32) -> Option<u64> {
    blocks_offset.checked_add(block_count as u64 * BLOCK_BYTES)
}

/// Hash that names the scene's content (see the header's `content_hash`).
pub fn content_hash(header: &Header, tables: &Tables) -> [u64; 2] {
    hash_tables(header, |s| {
        s.update(bytemuck::cast_slice(tables.nodes));
        s.update(bytemuck::cast_slice(tables.blocks));
        s.update(bytemuck::cast_slice(tables.instances));
        s.update(bytemuck::cast_slice(tables.images));
        s.update(bytemuck::cast_slice(tables.textures));
    })
}

/// The file's tables, as [`content_hash`] covers them.
#[derive(Clone, Copy, Debug, Default)]
pub struct Tables<'a> {
    pub nodes: &'a [NodeRecord],
    pub blocks: &'a [BlockRecord],
    pub instances: &'a [InstanceRecord],
    pub images: &'a [ImageRecord],
    pub textures: &'a [TextureRecord],
}

/// [`content_hash`] of the header and the tables that `tables` feeds in file order.
pub fn hash_tables(header: &Header, tables: impl FnOnce(&mut xxhash_rust::xxh3::Xxh3)) -> [u64; 2] {
    let mut h = *header;
    h.content_hash = [0; 2];
    h.header_hash = 0;
    let mut s = xxhash_rust::xxh3::Xxh3::new();
    s.update(bytemuck::bytes_of(&h));
    tables(&mut s);
    let v = s.digest128();
    [v as u64, (v >> 64) as u64]
}

/// Hash of the header with its own hash zeroed.
pub fn header_hash(header: &Header) -> u64 {
    let mut h = *header;
    h.header_hash = 0;
    xxhash_rust::xxh3::xxh3_64(bytemuck::bytes_of(&h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn record_sizes_are_stable() {
        assert_eq!(std::mem::size_of::<Header>(), 256);
        assert_eq!(std::mem::size_of::<NodeRecord>(), 104);
        assert_eq!(std::mem::size_of::<InstanceRecord>(), 104);
        assert_eq!(std::mem::size_of::<BlockRecord>(), 56);
        assert_eq!(std::mem::size_of::<ClusterRecord>(), 100);
        assert_eq!(IMAGE_BYTES, 40);
        assert_eq!(TEXTURE_BYTES, 16);
        assert_eq!(CUT_BYTES, 40);
    }
}
