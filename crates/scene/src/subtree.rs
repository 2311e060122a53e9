//! Stages 3 to 5 of the build: the geometry of the BVH's nodes, subtree by subtree, written as
//! it is made, and the node and block tables at the end.
//!
//! A leaf gets its LOD chain (occlusion switch sec. 4.1), a group an HLOD made from its children's
//! coarsest representations: per child its HLOD or coarsest LOD, or, for a child group without
//! an HLOD, its own children's, recursively. So a node needs nothing of its subtree but those
//! coarsest representations, which are all this keeps of a node until its parent is built: a
//! subtree of any size is built in the memory of one subtree, and the groups above the
//! subtrees from their roots' representations.

use crate::build::{BuildError, BuildReport, Progress, Times};
use crate::bvh::BvhNode;
use crate::format::{BlockRecord, NONE, NodeKind, NodeRecord};
use crate::hlod::NoHlod;
use crate::lod::{Level, LodStats};
use crate::mesh::Mesh;
use crate::spill::Sealed;
use crate::stream::Chunk;
use crate::writer::{Encoded, SceneWriter, encode};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::ops::Range;

/// The nodes built so far.
pub struct Built<'a> {
    tree: &'a [BvhNode],
    chunks: &'a [Chunk],
    closed_objects: &'a [Option<crate::Aabb>],
    min_error: f32,
    /// Per BVH node, its levels in `levels` (finest first; a group has at most its HLOD).
    lods: Vec<Range<u32>>,
    /// Every LOD and HLOD node built, and its block (offset in the blob, not yet its id).
    levels: Vec<(NodeRecord, BlockRecord)>,
    /// Coarsest representations of the nodes whose parent is not built yet.
    coarse: FxHashMap<u32, Vec<Level>>,
    lod_stats: LodStats,
    not_coarser: u64,
    vanished: u64,
}

/// Subtrees to build together: their nodes layer by layer, their leaves and the leaves' chunks.
pub struct Bucket {
    layers: Vec<Vec<u32>>,
    leaves: Vec<u32>,
    meshes: Vec<Mesh>,
}

/// Reads the chunks of the subtrees under `roots` from the spill, in the order they lie in it
/// (the next bucket is read this way while the current one is built, see [`crate::build`]).
pub fn read(tree: &[BvhNode], chunks: &[Chunk], spill: &Sealed, roots: &[u32]) -> std::io::Result<Bucket> {
    let layers = layers(tree, roots, |_| false);
    let leaves: Vec<u32> = layers.iter().flatten().copied().filter(|&id| tree[id as usize].item.is_some()).collect();
    let chunk = |k: usize| &chunks[tree[leaves[k] as usize].item.expect("a leaf") as usize];
    let mut order: Vec<usize> = (0..leaves.len()).collect();
    order.sort_unstable_by_key(|&k| chunk(k).spill.offset);
    let mut meshes = vec![Mesh::default(); leaves.len()];
    for k in order {
        meshes[k] = spill.read(&chunk(k).spill)?;
    }
    Ok(Bucket { layers, leaves, meshes })
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
    pub fn new(tree: &'a [BvhNode], chunks: &'a [Chunk], closed_objects: &'a [Option<crate::Aabb>], min_error: f32) -> Built<'a> {
        Built {
            tree,
            chunks,
            closed_objects,
            min_error,
            lods: vec![0..0; tree.len()],
            levels: Vec::new(),
            coarse: FxHashMap::default(),
            lod_stats: LodStats::default(),
            not_coarser: 0,
            vanished: 0,
        }
    }

    /// Builds whole subtrees: their leaves, then their groups deepest first.
    pub fn subtrees(&mut self, bucket: Bucket, w: &mut SceneWriter, times: &mut Times, progress: &dyn Progress) -> Result<(), BuildError> {
        self.leaves(&bucket.leaves, bucket.meshes, w, times, progress)?;
        for layer in bucket.layers.iter().rev() {
            let groups: Vec<u32> = layer.iter().copied().filter(|&id| self.tree[id as usize].item.is_none()).collect();
            self.groups(&groups, w, times)?;
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
            self.push(id, &levels, object, blocks, w, times)?;
            progress.advance(chunk(id).triangles as u64);
            self.coarse.insert(id, vec![levels.pop().expect("level 0")]);
        }
        Ok(())
    }

    /// HLODs of `groups`, whose children are all built.
    pub fn groups(&mut self, groups: &[u32], w: &mut SceneWriter, times: &mut Times) -> Result<(), BuildError> {
        let parts: Vec<Vec<Level>> = groups
            .iter()
            .map(|&g| self.tree[g as usize].children.clone().flat_map(|c| self.coarse.remove(&c).expect("children built first")).collect())
            .collect();
        let min_error = self.min_error;
        let hlods: Vec<Result<Level, NoHlod>> =
            times.run("hlod", || parts.par_iter().map(|p| crate::hlod::build(&p.iter().collect::<Vec<_>>(), min_error)).collect());
        let encoded: Vec<Option<Encoded>> =
            times.run("encode", || hlods.par_iter().map(|h| h.as_ref().ok().map(|h| encode(&h.mesh, None))).collect());
        for ((&g, (hlod, parts)), e) in groups.iter().zip(hlods.into_iter().zip(parts)).zip(encoded) {
            let coarse = match (hlod, e) {
                (Ok(h), Some(e)) => {
                    self.push(g, std::slice::from_ref(&h), NONE, vec![e], w, times)?;
                    vec![h]
                }
                (Err(why), _) => {
                    *(if why == NoHlod::NotCoarser { &mut self.not_coarser } else { &mut self.vanished }) += 1;
                    parts
                }
                (Ok(_), None) => unreachable!("every HLOD is encoded"),
            };
            self.coarse.insert(g, coarse);
        }
        Ok(())
    }

    /// Writes node `id`'s levels and their blocks.
    fn push(
        &mut self,
        id: u32,
        levels: &[Level],
        object: u32,
        blocks: Vec<Encoded>,
        w: &mut SceneWriter,
        times: &mut Times,
    ) -> Result<(), BuildError> {
        let start = self.levels.len() as u32;
        for (l, e) in levels.iter().zip(blocks) {
            let block = times
                .run("write", || w.block(e))
                .map_err(|e| BuildError::Write { path: w.partial_path().display().to_string(), error: e })?;
            let b = l.mesh.bounds();
            let record = NodeRecord {
                bbox_min: b.min.into(),
                kind: NodeKind::Lod as u32,
                bbox_max: b.max.into(),
                error: l.error,
                parent: id,
                first_child: 0,
                child_count: 0,
                first_lod: 0,
                lod_count: 0,
                block: NONE,
                object,
                triangles: l.mesh.triangle_count() as u32,
            };
            self.levels.push((record, block));
        }
        self.lods[id as usize] = start..self.levels.len() as u32;
        Ok(())
    }

    /// The node table (BVH nodes breadth first, then each one's LODs contiguous, finest first)
    /// and the block table (block k belongs to LOD node bvh_count + k).
    pub fn tables(self, report: &mut BuildReport) -> (Vec<NodeRecord>, Vec<BlockRecord>) {
        let (tree, chunks) = (self.tree, self.chunks);
        let bvh_count = tree.len() as u32;
        let mut nodes: Vec<NodeRecord> = Vec::with_capacity(tree.len() + self.levels.len());
        let mut next_lod = bvh_count;
        for (id, n) in tree.iter().enumerate() {
            let lods = self.lods[id].clone();
            let chunk = n.item.map(|c| &chunks[c as usize]);
            report.lod_levels_max = report.lod_levels_max.max(if chunk.is_some() { lods.len() as u64 } else { 0 });
            report.hlod_nodes += u64::from(chunk.is_none() && !lods.is_empty());
            nodes.push(NodeRecord {
                bbox_min: n.bounds.min.into(),
                kind: if chunk.is_some() { NodeKind::Leaf } else { NodeKind::Group } as u32,
                bbox_max: n.bounds.max.into(),
                error: self.levels.get(lods.start as usize).filter(|_| !lods.is_empty()).map_or(0.0, |(l, _)| l.error),
                parent: n.parent.unwrap_or(NONE),
                first_child: if n.children.is_empty() { 0 } else { n.children.start },
                child_count: n.children.len() as u32,
                first_lod: next_lod,
                lod_count: lods.len() as u32,
                block: NONE,
                object: chunk.map_or(NONE, |c| c.object),
                triangles: chunk.map_or(0, |c| c.triangles),
            });
            next_lod += lods.len() as u32;
        }
        let mut blocks = Vec::with_capacity(self.levels.len());
        for lods in &self.lods {
            for (record, block) in &self.levels[lods.start as usize..lods.end as usize] {
                nodes.push(NodeRecord { block: blocks.len() as u32, ..*record });
                blocks.push(*block);
            }
        }
        // Bottom-up (children have larger ids): subtree triangles, and the error of a group
        // without an HLOD (the largest of its children's, so errors never decrease going up).
        for id in (0..tree.len()).rev() {
            let n = nodes[id];
            if n.kind() == NodeKind::Group {
                nodes[id].triangles = n.children().map(|c| nodes[c as usize].triangles).sum();
                if n.lod_count == 0 {
                    nodes[id].error = n.children().map(|c| nodes[c as usize].error).fold(0.0, f32::max);
                }
            }
        }
        report.leaves = tree.iter().filter(|n| n.item.is_some()).count() as u64;
        report.groups = tree.len() as u64 - report.leaves;
        report.lod_nodes = blocks.len() as u64;
        report.stored_triangles = nodes[bvh_count as usize..].iter().map(|l| l.triangles as u64).sum();
        report.nodes = nodes.len() as u64;
        crate::build::report_left_out(report, &self.lod_stats, self.not_coarser, self.vanished);
        (nodes, blocks)
    }
}
