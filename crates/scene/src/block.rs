//! One geometry block's bytes, encoded by the build and decoded in place by every reader:
//! positions, colours, normals and texture coordinates if any, the indices in cluster order (u16 when every index fits, else
//! u32), padding to 4 bytes and the clusters ([`crate::format`] lays out the file around them).

use crate::format::{BlockRecord, CUT_BYTES, ClusterRecord, Cut};
use crate::mesh::Mesh;
use crate::texture::{NO_TEXTURE, Texcoord};
use std::borrow::Cow;
use xxhash_rust::xxh3::xxh3_64;

/// One block's bytes, as [`crate::format`] lays them out, and its record without the offset.
pub struct Encoded {
    pub bytes: Vec<u8>,
    pub record: BlockRecord,
}

/// The bytes of one block. `object`: the box of
/// the block's object when that is closed (see [`crate::cluster::clusterize`]).
///
/// Vertices of bit-identical attributes are stored once: a cluster hierarchy's node gathers
/// pieces that share their borders and the original corners of simplified triangles (docs/measurements/2026-12-07-constants.md, "encode"). Connected
/// parts are joined by position already ([`crate::cluster`]).
pub fn encode(mesh: &Mesh, object: Option<crate::Aabb>) -> Encoded {
    let mesh = mesh.welded();
    let c = crate::cluster::clusterize(&mesh, object);
    encode_with(&mesh, &c.indices, &c.clusters, &[], Layers { occluders: c.occluders, opaque: c.opaque })
}

/// [`encode`] for a part of a cluster hierarchy: each cluster holds triangles of one cut.
pub fn encode_cut(piece: &crate::clod::Piece, object: Option<crate::Aabb>) -> Encoded {
    let mesh = piece.mesh.welded();
    let c = crate::cluster::clusterize_cut(&mesh, object, &piece.cuts, &piece.cut_of);
    encode_with(&mesh, &c.indices, &c.clusters, &c.cuts, Layers { occluders: c.occluders, opaque: c.opaque })
}

/// Where a block's clusters of each layer end (see [`crate::mesh::Layer`]): the opaque ones
/// at `occluders`, the cut-outs at `opaque`, the translucent ones at the last.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layers {
    pub occluders: u32,
    pub opaque: u32,
}

/// [`encode`] with the clusters made already: `indices` in cluster order, in `layers`; `cuts`
/// one per cluster, or none (every cluster drawn at every tau).
pub(crate) fn encode_with(mesh: &Mesh, indices: &[u32], clusters: &[ClusterRecord], cuts: &[Cut], layers: Layers) -> Encoded {
    debug_assert!(cuts.is_empty() || cuts.len() == clusters.len());
    let mut bytes = Vec::with_capacity(mesh.positions.len() * 16 + indices.len() * 4 + std::mem::size_of_val(clusters));
    bytes.extend_from_slice(bytemuck::cast_slice(&mesh.positions));
    bytes.extend_from_slice(mesh.colors.as_flattened());
    // A block of flat triangles alone stores no normals (see crate::normal).
    let normals: &[crate::normal::Normal] = if mesh.normals.iter().all(|&n| n == crate::normal::NO_NORMAL) { &[] } else { &mesh.normals };
    bytes.extend_from_slice(bytemuck::cast_slice(normals));
    // Likewise a block whose surfaces sample no texture.
    let texcoords: &[Texcoord] = if mesh.texcoords.iter().all(|t| t.texture == NO_TEXTURE) { &[] } else { &mesh.texcoords };
    bytes.extend_from_slice(bytemuck::cast_slice(texcoords));
    let index_bytes = if mesh.positions.len() <= 1 << 16 {
        bytes.extend(indices.iter().flat_map(|&i| (i as u16).to_le_bytes()));
        2
    } else {
        bytes.extend_from_slice(bytemuck::cast_slice(indices));
        4
    };
    bytes.resize(bytes.len().next_multiple_of(4), 0);
    bytes.extend_from_slice(bytemuck::cast_slice(clusters));
    bytes.extend_from_slice(bytemuck::cast_slice(cuts));
    let record = BlockRecord {
        offset: 0,
        hash: xxh3_64(&bytes),
        vertex_count: mesh.positions.len() as u32,
        index_count: mesh.indices.len() as u32,
        index_bytes,
        color_bytes: if mesh.colors.is_empty() { 0 } else { 4 },
        cluster_count: clusters.len() as u32,
        opaque_clusters: layers.opaque,
        cut_bytes: if cuts.is_empty() { 0 } else { CUT_BYTES },
        cut_out_clusters: layers.opaque - layers.occluders,
        normal_bytes: if normals.is_empty() { 0 } else { 4 },
        texcoord_bytes: if texcoords.is_empty() { 0 } else { std::mem::size_of::<Texcoord>() as u32 },
    };
    debug_assert_eq!(record.byte_len(), bytes.len() as u64);
    Encoded { bytes, record }
}

/// One geometry block: a view of it in the mapped file, or, for a use of a mesh stored once,
/// its positions, clusters and (where mirrored) indices placed.
#[derive(Clone, Debug)]
pub struct Geometry<'a> {
    pub positions: Cow<'a, [[f32; 3]]>,
    /// One per vertex, or empty when the block has no colours.
    pub colors: &'a [[u8; 4]],
    /// One per vertex, or empty when the block has no normals; an instance's turned.
    pub normals: Cow<'a, [crate::normal::Normal]>,
    /// One per vertex, or empty when the block samples no texture.
    pub texcoords: &'a [Texcoord],
    /// In cluster order: `clusters` cover `indices` in turn (see [`ClusterRecord`]).
    pub indices: Indices<'a>,
    pub clusters: Cow<'a, [ClusterRecord]>,
    /// Where the cut draws each cluster, in a cluster hierarchy's block; empty elsewhere.
    pub cuts: &'a [Cut],
    /// `clusters[..occluders]` are opaque, `occluders..opaque` cut-outs, the rest translucent
    /// ([`BlockRecord::opaque_clusters`], [`BlockRecord::cut_out_clusters`]).
    pub occluders: usize,
    pub opaque: usize,
}

impl Geometry<'_> {
    /// Where the cut draws cluster `k`: [`Cut::ALWAYS`] outside a cluster hierarchy.
    pub fn cut(&self, k: usize) -> &Cut {
        self.cuts.get(k).unwrap_or(&Cut::ALWAYS)
    }

    /// Indices of the opaque clusters and the cut-outs: they come first, `0..opaque_indices()`.
    pub fn opaque_indices(&self) -> usize {
        self.clusters.get(self.opaque).map_or(self.indices.len(), |c| c.first_index as usize)
    }

    /// Indices of the opaque clusters, the occluders: `0..occluder_indices()`.
    pub fn occluder_indices(&self) -> usize {
        self.clusters.get(self.occluders).map_or(self.indices.len(), |c| c.first_index as usize)
    }
}

#[derive(Clone, Debug)]
pub enum Indices<'a> {
    U16(Cow<'a, [u16]>),
    U32(Cow<'a, [u32]>),
}

impl Indices<'_> {
    pub fn len(&self) -> usize {
        match self {
            Indices::U16(s) => s.len(),
            Indices::U32(s) => s.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn get(&self, i: usize) -> u32 {
        match self {
            Indices::U16(s) => s[i] as u32,
            Indices::U32(s) => s[i],
        }
    }

    pub fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }

    pub fn bytes(&self) -> &[u8] {
        match self {
            Indices::U16(s) => bytemuck::cast_slice(s.as_ref()),
            Indices::U32(s) => bytemuck::cast_slice(s.as_ref()),
        }
    }
}

/// A block's bytes read in place ([`ranges_ok`] says whether they can be trusted).
pub fn geometry_of<'a>(bytes: &'a [u8], rec: &BlockRecord) -> Geometry<'a> {
    let (front, clusters) = bytes.split_at(rec.clusters_at() as usize);
    let (clusters, cuts) = clusters.split_at(rec.cluster_count as usize * crate::format::CLUSTER_BYTES as usize);
    let (pos, rest) = front.split_at(rec.vertex_count as usize * 12);
    let (colors, rest) = rest.split_at(rec.vertex_count as usize * rec.color_bytes as usize);
    let (normals, rest) = rest.split_at(rec.vertex_count as usize * rec.normal_bytes as usize);
    let (texcoords, idx) = rest.split_at(rec.vertex_count as usize * rec.texcoord_bytes as usize);
    let idx = &idx[..rec.index_count as usize * rec.index_bytes as usize];
    let indices = if rec.index_bytes == 2 {
        Indices::U16(Cow::Borrowed(bytemuck::cast_slice(idx)))
    } else {
        Indices::U32(Cow::Borrowed(bytemuck::cast_slice(idx)))
    };
    Geometry {
        positions: Cow::Borrowed(bytemuck::cast_slice(pos)),
        colors: bytemuck::cast_slice(colors),
        normals: Cow::Borrowed(bytemuck::cast_slice(normals)),
        texcoords: bytemuck::cast_slice(texcoords),
        indices,
        clusters: Cow::Borrowed(bytemuck::cast_slice(clusters)),
        cuts: bytemuck::cast_slice(&cuts[..rec.cluster_count as usize * rec.cut_bytes as usize]),
        occluders: rec.opaque_clusters.saturating_sub(rec.cut_out_clusters) as usize,
        opaque: rec.opaque_clusters as usize,
    }
}

/// Every index names a vertex of the block, the clusters cover the indices in turn, and every
/// texture coordinate names one of `textures` or none.
pub fn ranges_ok(bytes: &[u8], rec: &BlockRecord, textures: u32) -> bool {
    let g = geometry_of(bytes, rec);
    let mut next = 0u32;
    let clusters_ok = g.clusters.iter().all(|c| {
        let ok = c.first_index == next && c.index_count.is_multiple_of(3) && c.radius.is_finite() && c.center.iter().all(|x| x.is_finite());
        next = next.saturating_add(c.index_count);
        ok
    });
    let texcoords_ok = g.texcoords.iter().all(|t| t.texture < textures || t.texture == NO_TEXTURE);
    clusters_ok && texcoords_ok && next == rec.index_count && g.indices.iter().all(|i| i < rec.vertex_count)
}
