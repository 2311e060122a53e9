//! Stages 3 to 5 of the build: the geometry of the BVH's nodes, subtree by subtree, written as
//! it is made, and the node and block tables at the end.
//!
//! A leaf gets its LOD chain (occlusion switch sec. 4.1), a group an HLOD made from its children's
//! coarsest representations: per child its HLOD or coarsest LOD (a use of a mesh stored once:
//! its first stand-in), or, for a child group without an HLOD, its own children's,
//! recursively. So a node needs nothing of its subtree but those coarsest representations,
//! which are all this keeps of a node until its parent is built: a subtree of any size is
//! built in the memory of one subtree, and the groups above the subtrees from their roots'
//! representations.
//!
//! With cluster hierarchies ([`crate::clod`]) a node's geometry is its cut node instead: its
//! chunk (a leaf) and the simplified groups it owns ([`super::owner`]), one block whose clusters
//! a cut takes one by one. Its coarsest representation is what its groups never simplify
//! further, and a group gets an HLOD only where no object under it reaches outside it.

use super::error::BuildError;
use super::options::{BuildOptions, Instances, Lod};
use super::owner::Owners;
use super::report::{BuildReport, GroupsNotBuilt, Times};
use super::stream::{Chunk, Chunked, Prototypes};
use crate::block::{Encoded, encode, encode_cut};
use crate::bvh::BvhNode;
use crate::clod::Piece;
use crate::format::{BlockRecord, ErrorBound, FLAG_BOUNDED, FLAG_CUT, InstanceRecord, NONE, NodeKind, NodeRecord};
use crate::hlod::NoHlod;
use crate::instance::Placement;
use crate::lod::{Level, LodStats};
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::spill::Sealed;
use crate::writer::SceneWriter;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::ops::Range;

/// The nodes built so far.
pub struct Built<'a> {
    tree: &'a [BvhNode],
    chunks: &'a [Chunk],
    closed_objects: &'a [Option<crate::Aabb>],
    min_error: f32,
    lod: Lod,
    owners: &'a Owners,
    prototypes: &'a Prototypes,
    instances: &'a [InstanceRecord],
    expand: bool,
    /// The prototypes' parts built so far.
    parts: FxHashMap<u32, PartLods>,
    /// Bytes of the blocks that instances' nodes name, and of those blocks once each.
    shared_bytes: u64,
    part_bytes: u64,
    part_triangles: u64,
    /// Per BVH node, its levels in `levels`: its cut node if any, then its static levels
    /// finest first (a group has at most its HLOD).
    lods: Vec<Range<u32>>,
    /// Every LOD and HLOD node built, and its block (offset in the blob, not yet its id).
    levels: Vec<(NodeRecord, BlockRecord)>,
    /// Coarsest representations of the nodes whose parent is not built yet.
    coarse: FxHashMap<u32, Vec<Level>>,
    lod_stats: LodStats,
    not_coarser: u64,
    vanished: u64,
    /// Groups left without an HLOD because an object under them reaches outside.
    open: u64,
}

/// A part of a prototype built: its levels in its frame, finest first, and what its uses leave
/// for their parents' HLODs.
struct PartLods {
    levels: Vec<PartLevel>,
    for_hlod: Level,
}

struct PartLevel {
    bounds: crate::Aabb,
    error: f32,
    triangles: u64,
    /// Written once (`--instances keep`), or kept to write a placed copy per use.
    block: Result<BlockRecord, Encoded>,
}

/// Subtrees to build together: their nodes layer by layer, their leaves and the leaves'
/// chunks (empty for a leaf placing a prototype's part), the parts first needed here, and the
/// simplified groups their nodes own.
pub struct Bucket {
    layers: Vec<Vec<u32>>,
    leaves: Vec<u32>,
    meshes: Vec<Piece>,
    parts: Vec<(u32, Mesh)>,
    owned: FxHashMap<u32, Owned>,
}

/// The simplified groups a node owns, in one piece, and their object (NONE when several).
pub type Owned = (Piece, u32);

/// The simplified groups (`coarse` read back from `spill`, owners' lists `owned`) that `nodes`
/// own, one piece per node that owns any.
pub fn read_owned(nodes: &[u32], coarse: &[Chunk], owned: &[Vec<u32>], spill: &Sealed) -> std::io::Result<FxHashMap<u32, Owned>> {
    let mut out = FxHashMap::default();
    for &id in nodes {
        for &k in owned.get(id as usize).into_iter().flatten() {
            let c = &coarse[k as usize];
            let (piece, object) = out.entry(id).or_insert_with(|| (Piece::default(), c.object));
            piece.append(&spill.read(&c.spill)?);
            if *object != c.object {
                *object = NONE;
            }
        }
    }
    Ok(out)
}

/// Reads the chunks of the subtrees under `roots` from the spill, in the order they lie in it
/// (the next bucket is read this way while the current one is built, see [`super`]),
/// and the prototypes' parts for which `first_needed` says so.
pub fn read(
    tree: &[BvhNode],
    chunked: &Chunked,
    owned: &[Vec<u32>],
    spill: &Sealed,
    roots: &[u32],
    first_needed: impl Fn(u32) -> bool,
) -> std::io::Result<Bucket> {
    let layers = layers(tree, roots, |_| false);
    let leaves: Vec<u32> = layers.iter().flatten().copied().filter(|&id| tree[id as usize].item.is_some()).collect();
    let chunk = |k: usize| &chunked.chunks[tree[leaves[k] as usize].item.expect("a leaf") as usize];
    let mut order: Vec<usize> = (0..leaves.len()).collect();
    order.sort_unstable_by_key(|&k| chunk(k).spill.offset);
    let mut meshes = vec![Piece::default(); leaves.len()];
    let mut parts = Vec::new();
    let mut part_read = rustc_hash::FxHashSet::default();
    for k in order {
        let c = chunk(k);
        if c.part == NONE {
            meshes[k] = spill.read(&c.spill)?;
        } else if first_needed(c.part) && part_read.insert(c.part) {
            parts.push((c.part, spill.read(&c.spill)?.mesh));
        }
    }
    let owned = read_owned(&layers.concat(), &chunked.coarse, owned, spill)?;
    Ok(Bucket { layers, leaves, meshes, parts, owned })
}

/// Breadth-first layers of the subtrees under `roots`, not entering `stop` nodes (which are
/// built already).
pub fn layers(tree: &[BvhNode], roots: &[u32], stop: impl Fn(u32) -> bool) -> Vec<Vec<u32>> {
    let mut layers = vec![roots.to_vec()];
    loop {
        let next: Vec<u32> =
            layers.last().expect("roots").iter().flat_map(|&id| tree[id as usize].children.clone()).filter(|&c| !stop(c)).collect();
        if next.is_empty() {
            return layers;
        }
        layers.push(next);
    }
}

impl<'a> Built<'a> {
    pub fn new(tree: &'a [BvhNode], chunked: &'a Chunked, owners: &'a Owners, min_error: f32, opts: &BuildOptions) -> Built<'a> {
        Built {
            tree,
            chunks: &chunked.chunks,
            closed_objects: &chunked.closed_objects,
            min_error,
            lod: opts.lod,
            owners,
            prototypes: &chunked.prototypes,
            instances: &chunked.instances,
            expand: opts.instances == Instances::Expand,
            parts: FxHashMap::default(),
            shared_bytes: 0,
            part_bytes: 0,
            part_triangles: 0,
            lods: vec![0..0; tree.len()],
            // Reserved, not touched: growing it at ten million nodes would hold the old and
            // the new array at once, the build's peak.
            levels: Vec::with_capacity(tree.len() * 4),
            coarse: FxHashMap::default(),
            lod_stats: LodStats::default(),
            not_coarser: 0,
            vanished: 0,
            open: 0,
        }
    }

    /// Builds whole subtrees: their leaves, then their groups deepest first.
    pub fn subtrees(
        &mut self,
        mut bucket: Bucket,
        w: &mut SceneWriter,
        times: &mut Times,
        progress: &dyn Progress,
    ) -> Result<(), BuildError> {
        match self.lod {
            Lod::Chains => {
                self.parts(bucket.parts, w, times)?;
                self.leaves(&bucket.leaves, bucket.meshes.into_iter().map(|p| p.mesh).collect(), w, times, progress)?
            }
            Lod::Clusters => {
                let pieces = bucket.leaves.iter().zip(bucket.meshes).map(|(id, mut p)| {
                    if let Some((o, _)) = bucket.owned.remove(id) {
                        p.append(&o);
                    }
                    p
                });
                let pieces: Vec<Piece> = pieces.collect();
                self.cut_leaves(&bucket.leaves, pieces, w, times, progress)?;
            }
        }
        for layer in bucket.layers.iter().rev() {
            let groups: Vec<u32> = layer.iter().copied().filter(|&id| self.tree[id as usize].item.is_none()).collect();
            let owned = groups.iter().filter_map(|id| bucket.owned.remove_entry(id)).collect();
            self.groups(&groups, owned, w, times)?;
        }
        Ok(())
    }

    /// Cut nodes of `leaves`, whose chunks with the simplified groups they own are `pieces`.
    fn cut_leaves(
        &mut self,
        leaves: &[u32],
        pieces: Vec<Piece>,
        w: &mut SceneWriter,
        times: &mut Times,
        progress: &dyn Progress,
    ) -> Result<(), BuildError> {
        let chunk = |id: u32| &self.chunks[self.tree[id as usize].item.expect("a leaf") as usize];
        let encoded: Vec<Encoded> = times.run("encode", || {
            pieces.par_iter().zip(leaves).map(|(p, &id)| encode_cut(p, self.closed_objects[chunk(id).object as usize])).collect()
        });
        for ((&id, p), e) in leaves.iter().zip(pieces).zip(encoded) {
            let object = chunk(id).object;
            let record = cut_record(id, &p, object);
            self.write(id, vec![(record, e)], w, times)?;
            progress.advance(chunk(id).triangles as u64);
            self.coarse.insert(id, coarsest(&p));
        }
        Ok(())
    }

    /// LOD chains of `leaves`, whose chunks are `meshes`.
    fn leaves(
        &mut self,
        leaves: &[u32],
        meshes: Vec<Mesh>,
        w: &mut SceneWriter,
        times: &mut Times,
        progress: &dyn Progress,
    ) -> Result<(), BuildError> {
        let chunk = |id: u32| &self.chunks[self.tree[id as usize].item.expect("a leaf") as usize];
        let (placing, own): (Vec<_>, Vec<_>) = leaves.iter().copied().zip(meshes).partition(|&(id, _)| chunk(id).part != NONE);
        for (id, _) in placing {
            self.place(id, w, times)?;
            progress.advance(chunk(id).triangles as u64);
        }
        let (leaves, meshes): (Vec<u32>, Vec<Mesh>) = own.into_iter().unzip();
        let leaves = &leaves[..];
        let min_error = self.min_error;
        let chains: Vec<(Vec<Level>, LodStats)> =
            times.run("lod", || meshes.into_par_iter().map(|m| crate::lod::chain(m, min_error)).collect());
        let encoded: Vec<Vec<Encoded>> = times.run("encode", || {
            chains
                .par_iter()
                .zip(leaves)
                .map(|((levels, _), &id)| {
                    // Only level 0 is the object's own geometry; a simplified level may have
                    // lost the object's closure.
                    let object = self.closed_objects[chunk(id).object as usize];
                    levels.iter().enumerate().map(|(k, l)| encode(&l.mesh, if k == 0 { object } else { None })).collect()
                })
                .collect()
        });
        for ((&id, (mut levels, stats)), blocks) in leaves.iter().zip(chains).zip(encoded) {
            self.lod_stats.add(stats);
            let object = chunk(id).object;
            let records = levels.iter().map(|l| mesh_record(id, l, object)).zip(blocks).collect();
            self.write(id, records, w, times)?;
            progress.advance(chunk(id).triangles as u64);
            self.coarse.insert(id, vec![levels.pop().expect("level 0")]);
        }
        Ok(())
    }

    /// LOD chains of prototypes' `parts` (each in its mesh's frame), in their prototype's units:
    /// a level's error in the scene is at most its scale times larger.
    fn parts(&mut self, parts: Vec<(u32, Mesh)>, w: &mut SceneWriter, times: &mut Times) -> Result<(), BuildError> {
        let p = self.prototypes;
        let prototype = |part: u32| p.parts[part as usize].prototype as usize;
        let min_error = self.min_error;
        // Built once for all its uses, a part's chain ends in stand-ins: what far uses draw,
        // from the chain's first step that jumps. Each use leaves the first for its parent's
        // HLOD (a coarser one would carry its error into every HLOD above).
        let chains: Vec<(u32, (Vec<Level>, LodStats), usize)> = times.run("lod", || {
            parts
                .into_par_iter()
                .map(|(k, m)| {
                    let min_error = min_error / p.scale[prototype(k)].max(1e-30);
                    let (mut levels, stats) = crate::lod::chain(m, min_error);
                    let chained = crate::hlod::stand_ins(&mut levels, min_error);
                    let for_hlod = chained.min(levels.len() - 1);
                    (k, (levels, stats), for_hlod)
                })
                .collect()
        });
        let encoded: Vec<Vec<Encoded>> = times.run("encode", || {
            chains
                .par_iter()
                .map(|(k, (levels, _), _)| {
                    let closed = p.closed[prototype(*k)];
                    levels.iter().enumerate().map(|(i, l)| encode(&l.mesh, if i == 0 { closed } else { None })).collect()
                })
                .collect()
        });
        for ((k, (mut levels, stats), for_hlod), blocks) in chains.into_iter().zip(encoded) {
            self.lod_stats.add(stats);
            let mut out = Vec::with_capacity(levels.len());
            for (l, e) in levels.iter().zip(blocks) {
                let block = if self.expand {
                    Err(e)
                } else {
                    self.part_bytes += e.bytes.len().next_multiple_of(crate::limits::BLOCK_ALIGN as usize) as u64;
                    self.part_triangles += l.mesh.triangle_count() as u64;
                    Ok(times.run("write", || w.block(e)).map_err(|e| write_error(w, e))?)
                };
                out.push(PartLevel { bounds: l.mesh.bounds(), error: l.error, triangles: l.mesh.triangle_count() as u64, block });
            }
            self.parts.insert(k, PartLods { levels: out, for_hlod: levels.swap_remove(for_hlod) });
        }
        Ok(())
    }

    /// The LOD nodes of leaf `id`, which places a prototype's part: the part's levels, placed.
    fn place(&mut self, id: u32, w: &mut SceneWriter, times: &mut Times) -> Result<(), BuildError> {
        let c = self.chunks[self.tree[id as usize].item.expect("a leaf") as usize];
        let place = Placement::new(self.instances[c.instance as usize].affine());
        let part = &self.parts[&c.part];
        let start = self.levels.len() as u32;
        for l in &part.levels {
            // Simplification keeps a subset of the part's vertices, so the level lies in the leaf.
            let b = place.bounds(l.bounds);
            let bounds = crate::Aabb::new(b.min.max(c.bounds.min), b.max.min(c.bounds.max));
            let instance = if self.expand { NONE } else { c.instance };
            let record = NodeRecord { instance, ..level_record(id, bounds, l.error * place.scale, l.triangles, c.object) };
            let block = match &l.block {
                Ok(block) => {
                    self.shared_bytes += block.byte_len().next_multiple_of(crate::limits::BLOCK_ALIGN);
                    *block
                }
                Err(e) => {
                    let placed = crate::instance::place_block(e, &place);
                    times.run("write", || w.block(placed)).map_err(|e| write_error(w, e))?
                }
            };
            self.levels.push((record, block));
        }
        self.lods[id as usize] = start..self.levels.len() as u32;
        let l = &part.for_hlod;
        self.coarse.insert(id, vec![Level { mesh: place.mesh(&l.mesh), error: l.error * place.scale }]);
        Ok(())
    }

    /// Cut nodes (from the simplified groups they own, `owned`) and HLODs of `groups`, whose
    /// children are all built.
    pub fn groups(
        &mut self,
        groups: &[u32],
        mut owned: FxHashMap<u32, Owned>,
        w: &mut SceneWriter,
        times: &mut Times,
    ) -> Result<(), BuildError> {
        let own: Vec<Option<Owned>> = groups.iter().map(|g| owned.remove(g)).collect();
        let parts: Vec<Vec<Level>> = groups
            .iter()
            .zip(&own)
            .map(|(&g, p)| {
                let mut parts: Vec<Level> =
                    self.tree[g as usize].children.clone().flat_map(|c| self.coarse.remove(&c).expect("children built first")).collect();
                parts.extend(p.as_ref().map(|(p, _)| coarsest(p)).into_iter().flatten());
                parts
            })
            .collect();
        let min_error = self.min_error;
        let open = &self.owners.open;
        let hlods: Vec<Result<Level, NoHlod>> = times.run("hlod", || {
            groups
                .par_iter()
                .zip(&parts)
                .map(
                    |(&g, p)| {
                        if open[g as usize] { Err(NoHlod::Open) } else { crate::hlod::build(&p.iter().collect::<Vec<_>>(), min_error) }
                    },
                )
                .collect()
        });
        let encoded: Vec<(Option<Encoded>, Option<Encoded>)> = times.run("encode", || {
            hlods
                .par_iter()
                .zip(&own)
                .map(|(h, p)| (p.as_ref().map(|(p, _)| encode_cut(p, None)), h.as_ref().ok().map(|h| encode(&h.mesh, None))))
                .collect()
        });
        for (((&g, (hlod, parts)), p), (cut, e)) in groups.iter().zip(hlods.into_iter().zip(parts)).zip(own).zip(encoded) {
            let mut records: Vec<(NodeRecord, Encoded)> = p.iter().map(|(p, object)| cut_record(g, p, *object)).zip(cut).collect();
            let coarse = match (hlod, e) {
                (Ok(h), Some(e)) => {
                    records.push((mesh_record(g, &h, NONE), e));
                    vec![h]
                }
                (Err(why), _) => {
                    match why {
                        NoHlod::NotCoarser => self.not_coarser += 1,
                        NoHlod::Vanished => self.vanished += 1,
                        NoHlod::Open => self.open += 1,
                    }
                    parts
                }
                (Ok(_), None) => unreachable!("every HLOD is encoded"),
            };
            self.write(g, records, w, times)?;
            self.coarse.insert(g, coarse);
        }
        Ok(())
    }

    /// Writes node `id`'s LOD nodes and their blocks.
    fn write(&mut self, id: u32, levels: Vec<(NodeRecord, Encoded)>, w: &mut SceneWriter, times: &mut Times) -> Result<(), BuildError> {
        let start = self.levels.len() as u32;
        for (record, e) in levels {
            let block = times.run("write", || w.block(e)).map_err(|e| write_error(w, e))?;
            self.levels.push((record, block));
        }
        self.lods[id as usize] = start..self.levels.len() as u32;
        Ok(())
    }

    /// The node table: the BVH nodes breadth first, and after them each one's LOD nodes
    /// contiguous, finest first, each with its block record (LOD node `bvh_count + k` has
    /// block `k`). The LOD nodes are the built levels put in id order in place: at a billion
    /// triangles they are most of the build's memory, and the writer streams them.
    pub fn tables(mut self, report: &mut BuildReport) -> (Vec<NodeRecord>, Vec<(NodeRecord, BlockRecord)>) {
        let (tree, chunks) = (self.tree, self.chunks);
        let bvh_count = tree.len() as u32;
        let mut nodes: Vec<NodeRecord> = Vec::with_capacity(tree.len());
        let mut dest = vec![0u32; self.levels.len()];
        let mut next_lod = 0u32;
        for (id, n) in tree.iter().enumerate() {
            let lods = self.lods[id].clone();
            let chunk = n.item.map(|c| &chunks[c as usize]);
            let levels = &self.levels[lods.start as usize..lods.end as usize];
            let statics = levels.iter().filter(|(l, _)| !l.is_cut()).count() as u64;
            report.cut_nodes += levels.len() as u64 - statics;
            report.lod_levels_max = report.lod_levels_max.max(if chunk.is_some() { statics } else { 0 });
            report.hlod_nodes += u64::from(chunk.is_none() && statics > 0);
            nodes.push(NodeRecord {
                bbox_min: n.bounds.min.into(),
                kind: if chunk.is_some() { NodeKind::Leaf } else { NodeKind::Group } as u32,
                bbox_max: n.bounds.max.into(),
                // Its finest static representation's (a cut node's finest is the original).
                error: levels.iter().find(|(l, _)| !l.is_cut()).map_or(0.0, |(l, _)| l.error),
                parent: n.parent.unwrap_or(NONE),
                first_child: if n.children.is_empty() { 0 } else { n.children.start },
                child_count: n.children.len() as u32,
                first_lod: bvh_count + next_lod,
                lod_count: lods.len() as u32,
                block: NONE,
                object: chunk.map_or(NONE, |c| c.object),
                triangles: chunk.map_or(0, |c| c.triangles as u64),
                flags: 0,
                cut_hi: bytemuck::Zeroable::zeroed(),
                cut_lo_error: 0.0,
                instance: chunk.map_or(NONE, |c| if self.expand { NONE } else { c.instance }),
                _pad: 0,
            });
            for k in lods {
                dest[k as usize] = next_lod;
                next_lod += 1;
            }
        }
        // Into id order, cycle by cycle.
        let levels = &mut self.levels;
        for i in 0..levels.len() {
            while dest[i] as usize != i {
                let j = dest[i] as usize;
                levels.swap(i, j);
                dest.swap(i, j);
            }
        }
        drop(dest);
        for (k, (record, _)) in levels.iter_mut().enumerate() {
            record.block = k as u32;
        }
        let lod = |l: u32| &levels[(l - bvh_count) as usize].0;
        // Bottom-up (children have larger ids): subtree triangles, the error of a group
        // without an HLOD (the largest of its children's, so errors never decrease going up),
        // and, where the subtree holds only cluster hierarchies, the bound of its cut nodes.
        for id in (0..tree.len()).rev() {
            let n = nodes[id];
            if n.kind() == NodeKind::Leaf {
                nodes[id].flags = if self.lod == Lod::Clusters { FLAG_BOUNDED } else { 0 };
                continue;
            }
            nodes[id].triangles = n.children().map(|c| nodes[c as usize].triangles).sum();
            if n.lods().all(|l| lod(l).is_cut()) {
                nodes[id].error = n.children().map(|c| nodes[c as usize].error).fold(0.0, f32::max);
            }
            if n.children().all(|c| nodes[c as usize].is_bounded()) {
                let below: Vec<ErrorBound> = n
                    .children()
                    .flat_map(|c| {
                        let c = &nodes[c as usize];
                        let cut = c.lods().map(lod).find(|l| l.is_cut()).map(|l| l.cut_hi);
                        cut.into_iter().chain((c.kind() == NodeKind::Group).then_some(c.cut_hi))
                    })
                    .collect();
                nodes[id].flags = FLAG_BOUNDED;
                nodes[id].cut_hi = crate::clod::enclosing(&below, f32::max);
            }
        }
        report.leaves = tree.iter().filter(|n| n.item.is_some()).count() as u64;
        report.groups = tree.len() as u64 - report.leaves;
        report.lod_nodes = levels.len() as u64;
        // A block that instances share is stored once: the parts' blocks count once.
        let own: u64 = levels.iter().filter(|(l, _)| l.instance == NONE).map(|(l, _)| l.triangles).sum();
        report.stored_triangles = own + self.part_triangles;
        report.bytes_saved = self.shared_bytes.saturating_sub(self.part_bytes);
        report.nodes = (nodes.len() + levels.len()) as u64;
        super::report::report_left_out(
            report,
            &self.lod_stats,
            GroupsNotBuilt { not_coarser: self.not_coarser, vanished: self.vanished, open: self.open },
        );
        (nodes, self.levels)
    }
}

fn write_error(w: &SceneWriter, error: std::io::Error) -> BuildError {
    BuildError::Write { path: w.partial_path().display().to_string(), source: error }
}

/// The LOD node of a static level or HLOD of BVH node `id`.
fn level_record(id: u32, b: crate::Aabb, error: f32, triangles: u64, object: u32) -> NodeRecord {
    NodeRecord {
        bbox_min: b.min.into(),
        kind: NodeKind::Lod as u32,
        bbox_max: b.max.into(),
        error,
        parent: id,
        first_child: 0,
        child_count: 0,
        first_lod: 0,
        lod_count: 0,
        block: NONE,
        object,
        triangles,
        flags: 0,
        cut_hi: bytemuck::Zeroable::zeroed(),
        cut_lo_error: 0.0,
        instance: NONE,
        _pad: 0,
    }
}

/// The LOD node of level `l`.
fn mesh_record(id: u32, l: &Level, object: u32) -> NodeRecord {
    level_record(id, l.mesh.bounds(), l.error, l.mesh.triangle_count() as u64, object)
}

/// The cut node of BVH node `id` holding `p`: its bound encloses its triangles' `hi` bounds with
/// the largest error; its `lo` error (and error: the finest it draws) is their smallest.
fn cut_record(id: u32, p: &Piece, object: u32) -> NodeRecord {
    let hi: Vec<ErrorBound> = p.cuts.iter().map(|c| c.hi).collect();
    let lo_error = p.cuts.iter().map(|c| c.lo.error).fold(f32::INFINITY, f32::min);
    let b = p.mesh.bounds();
    NodeRecord {
        flags: FLAG_CUT,
        cut_hi: crate::clod::enclosing(&hi, f32::max),
        cut_lo_error: lo_error,
        ..level_record(id, b, lo_error, p.mesh.triangle_count() as u64, object)
    }
}

/// What a cut node's piece leaves for its parent's HLOD: the triangles never simplified
/// further.
fn coarsest(p: &Piece) -> Vec<Level> {
    let (mesh, error) = p.coarsest();
    if mesh.is_empty() { Vec::new() } else { vec![Level { mesh, error }] }
}
