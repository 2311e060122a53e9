//! The scene build: objects → placement around one origin → clean-up → chunks → BVH → LOD chains → HLODs → node table and
//! geometry blocks (paper 000 sec. 4.1), and the report of what it made and what it left out.

use crate::aabb::Aabb;
use crate::bvh;
use crate::chunk::{Chunks, SplitOptions};
use crate::format::{NONE, NodeKind, NodeRecord};
use crate::hlod::NoHlod;
use crate::limits::{CHUNK_TRIANGLES, LOOSE_SPLIT, MIN_RELATIVE_ERROR};
use crate::lod::{Level, LodStats};
use crate::mesh::{CleanStats, Mesh, MeshError, Object};
use crate::writer::{SceneData, write_scene};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// Settings of a build.
#[derive(Clone, Debug)]
pub struct BuildOptions {
    /// Largest chunk, triangles (>= 1).
    pub chunk_triangles: u32,
    /// Split chunks whose halves' boxes have less than this fraction of their box's surface
    /// area (0: never; see [`crate::limits::LOOSE_SPLIT`]).
    pub loose_split: f32,
    /// Keep the model's colours (false: every object in its hashed colour).
    pub model_colors: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions { chunk_triangles: CHUNK_TRIANGLES, loose_split: LOOSE_SPLIT, model_colors: true }
    }
}

/// Progress of a long build, reported per stage. `()` reports nothing.
pub trait Progress: Sync {
    fn stage(&self, name: &str, total: u64);
    fn advance(&self, n: u64);
}

impl Progress for () {
    fn stage(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
}

/// What the build made, written next to the scene as `<scene>.build.json`.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BuildReport {
    pub input: String,
    pub input_triangles: u64,
    pub objects: u64,
    /// Objects the model gives no colour (drawn in hashed colours), after clean-up.
    pub objects_without_color: u64,
    pub chunks: u64,
    /// Chunks split in two because their box was loose (see [`crate::chunk`]).
    pub loose_splits: u64,
    /// Objects closed and wound outwards: back faces of their chunks may be culled.
    pub closed_objects: u64,
    pub nodes: u64,
    pub leaves: u64,
    pub groups: u64,
    pub lod_nodes: u64,
    pub lod_levels_max: u64,
    pub hlod_nodes: u64,
    /// Triangles stored over all LOD and HLOD blocks.
    pub stored_triangles: u64,
    pub degenerate_triangles_dropped: u64,
    pub output_bytes: u64,
    pub content_hash: String,
    pub seconds: f64,
    pub input_triangles_per_second: f64,
    /// Peak resident memory of the building process (KiB; set by the caller, 0 if unknown).
    pub peak_rss_kb: u64,
    pub stage_seconds: BTreeMap<String, f64>,
    /// What the build left out and why.
    pub left_out: Vec<String>,
    pub notes: Vec<String>,
}

#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("object {index} ({name}): {source}")]
    Mesh { index: usize, name: String, source: MeshError },
    #[error("empty scene: {0}")]
    Empty(String),
    #[error("scene too large: {0}")]
    TooLarge(String),
    #[error("{path}: {source}")]
    Write { path: String, source: std::io::Error },
}

/// Builds the scene from `objects` and writes it to `out`. `input` names the source in the
/// report; `notes` go into the report as they are. `started` is when reading or generating the
/// input began, `input_seconds` how long that took: the report's times are end to end.
pub fn build_scene(
    objects: Vec<Object>,
    input: &str,
    notes: Vec<String>,
    opts: &BuildOptions,
    out: &Path,
    started: Instant,
    progress: &dyn Progress,
) -> Result<BuildReport, BuildError> {
    let mut report = BuildReport { input: input.to_owned(), notes, ..Default::default() };
    report.stage_seconds.insert("input".into(), started.elapsed().as_secs_f64());
    let scene = make_scene(objects, opts, &mut report, progress)?;
    let t = Instant::now();
    progress.stage("write", 1);
    let (bytes, hash) = write_scene(out, &scene).map_err(|source| BuildError::Write { path: out.display().to_string(), source })?;
    progress.advance(1);
    report.stage_seconds.insert("write".into(), t.elapsed().as_secs_f64());
    report.output_bytes = bytes;
    report.content_hash = format!("{:016x}{:016x}", hash[1], hash[0]);
    report.seconds = started.elapsed().as_secs_f64();
    report.input_triangles_per_second = report.input_triangles as f64 / report.seconds.max(1e-9);
    Ok(report)
}

fn timed<T>(report: &mut BuildReport, stage: &str, f: impl FnOnce(&mut BuildReport) -> T) -> T {
    let t = Instant::now();
    let r = f(report);
    report.stage_seconds.insert(stage.into(), t.elapsed().as_secs_f64());
    r
}

/// Every step but writing: the node table and blocks in memory.
pub fn make_scene(
    objects: Vec<Object>,
    opts: &BuildOptions,
    report: &mut BuildReport,
    progress: &dyn Progress,
) -> Result<SceneData, BuildError> {
    report.input_triangles = objects.iter().map(|o| o.mesh.triangle_count() as u64).sum();
    let (mut objects, origin) = timed(report, "place", |_| crate::place::place(objects));
    let colored = objects.iter().filter(|o| !o.mesh.colors.is_empty()).count();
    if !opts.model_colors && colored > 0 {
        objects.iter_mut().for_each(|o| o.mesh.colors = Vec::new());
        report.left_out.push(format!("the model's colours of {colored} objects (--colors hashed)"));
    }
    progress.stage("clean", objects.len() as u64);
    let objects = timed(report, "clean", |report| clean(objects, report, progress))?;
    report.objects = objects.len() as u64;
    report.objects_without_color = objects.iter().filter(|o| o.mesh.colors.is_empty()).count() as u64;
    let scene_box = objects.iter().fold(Aabb::EMPTY, |b, o| b.union(o.mesh.bounds()));
    let min_error = (MIN_RELATIVE_ERROR * scene_box.extent().length()).max(f32::MIN_POSITIVE);

    progress.stage("chunk", objects.len() as u64);
    let split = SplitOptions { max_triangles: opts.chunk_triangles, loose: opts.loose_split };
    // Whether each object is closed and wound outwards is decided on the whole object, before
    // chunks cut it open (see crate::cluster).
    let (per_object, closed_objects): (Vec<Chunks>, Vec<Option<Aabb>>) = timed(report, "chunk", |_| {
        objects
            .par_iter()
            .map(|o| {
                progress.advance(1);
                let closed = crate::cluster::Parts::of(&o.mesh).all_closed().then(|| o.mesh.bounds());
                (crate::chunk::split(&o.mesh, split), closed)
            })
            .unzip()
    });
    drop(objects);
    report.closed_objects = closed_objects.iter().filter(|c| c.is_some()).count() as u64;
    report.loose_splits = per_object.iter().map(|c| c.loose_splits as u64).sum();
    let chunks: Vec<(u32, Mesh)> =
        per_object.into_iter().enumerate().flat_map(|(i, c)| c.meshes.into_iter().map(move |m| (i as u32, m))).collect();
    report.chunks = chunks.len() as u64;

    let boxes: Vec<Aabb> = chunks.iter().map(|(_, m)| m.bounds()).collect();
    let tree = timed(report, "bvh", |_| bvh::build(&boxes));
    let lod_ids_max = tree.len() as u64 + chunks.iter().map(|_| crate::limits::LOD_MAX_LEVELS as u64).sum::<u64>() + tree.len() as u64;
    if lod_ids_max > crate::limits::MAX_NODES as u64 {
        return Err(BuildError::TooLarge(format!("{} chunks need more than 2^32 node ids", chunks.len())));
    }

    progress.stage("lod", chunks.len() as u64);
    let (chains, lod_stats) = timed(report, "lod", |_| {
        let chains: Vec<(Vec<Level>, LodStats)> = chunks
            .par_iter()
            .map(|(_, m)| {
                let r = crate::lod::chain(m, min_error);
                progress.advance(1);
                r
            })
            .collect();
        let mut stats = LodStats::default();
        chains.iter().for_each(|(_, s)| stats.add(*s));
        (chains.into_iter().map(|(c, _)| c).collect::<Vec<_>>(), stats)
    });

    let groups = tree.iter().filter(|n| n.item.is_none()).count() as u64;
    progress.stage("hlod", groups);
    let (hlods, hlod_stats) = timed(report, "hlod", |_| hlods(&tree, &chains, min_error, progress));

    let scene = SceneData { closed_objects, ..assemble(&tree, &chunks, chains, hlods, origin.to_array(), report) };
    report_left_out(report, &lod_stats, &hlod_stats, groups);
    Ok(scene)
}

fn clean(objects: Vec<Object>, report: &mut BuildReport, progress: &dyn Progress) -> Result<Vec<Object>, BuildError> {
    let cleaned: Vec<Result<(Object, CleanStats), BuildError>> = objects
        .into_par_iter()
        .enumerate()
        .map(|(index, o)| {
            progress.advance(1);
            let (mesh, stats) = o.mesh.clean().map_err(|source| BuildError::Mesh { index, name: o.name.clone(), source })?;
            Ok((Object { mesh, ..o }, stats))
        })
        .collect();
    let mut stats = CleanStats::default();
    let mut kept = Vec::with_capacity(cleaned.len());
    let mut empty = Vec::new();
    for r in cleaned {
        let (o, s) = r?;
        stats.add(s);
        if o.mesh.is_empty() {
            empty.push(o.name);
        } else {
            kept.push(o);
        }
    }
    report.degenerate_triangles_dropped = stats.degenerate_triangles;
    if stats.degenerate_triangles > 0 {
        report
            .left_out
            .push(format!("{} degenerate triangles (repeated index or zero area): they cover no pixel", stats.degenerate_triangles));
    }
    if !empty.is_empty() {
        let names: Vec<&str> = empty.iter().take(5).map(String::as_str).collect();
        report.left_out.push(format!("{} objects with no triangles left after clean-up, e.g. {}", empty.len(), names.join(", ")));
    }
    if kept.is_empty() {
        return Err(BuildError::Empty(format!("no triangles in the input ({} objects)", empty.len())));
    }
    Ok(kept)
}

/// HLOD per group, deepest level first so that a group's inputs exist when it is built. BVH
/// ids are breadth first, so each depth is a contiguous id range and children lie above it.
fn hlods(tree: &[bvh::BvhNode], chains: &[Vec<Level>], min_error: f32, progress: &dyn Progress) -> (Vec<Option<Level>>, HlodStats) {
    let mut depth = vec![0u32; tree.len()];
    for id in 1..tree.len() {
        depth[id] = depth[tree[id].parent.expect("non-root") as usize] + 1;
    }
    let mut reps: Vec<Option<Level>> = vec![None; tree.len()];
    let mut stats = HlodStats::default();
    let max_depth = depth.iter().copied().max().unwrap_or(0);
    for d in (0..=max_depth).rev() {
        let start = depth.partition_point(|&x| x < d);
        let end = depth.partition_point(|&x| x <= d);
        let (here, below) = reps.split_at_mut(end);
        let below = &*below;
        let built: Vec<Option<Result<Level, NoHlod>>> = (start..end)
            .into_par_iter()
            .map(|id| {
                tree[id].item.is_none().then(|| {
                    let mut parts = Vec::new();
                    coarse_parts(tree, chains, below, end, id, &mut parts);
                    progress.advance(1);
                    crate::hlod::build(&parts, min_error)
                })
            })
            .collect();
        for (slot, b) in here[start..end].iter_mut().zip(built) {
            match b {
                Some(Err(NoHlod::NotCoarser)) => stats.not_coarser += 1,
                Some(Err(NoHlod::Vanished)) => stats.vanished += 1,
                _ => {}
            }
            *slot = b.and_then(Result::ok);
        }
    }
    (reps, stats)
}

/// Why groups got no HLOD (see [`NoHlod`]).
#[derive(Clone, Copy, Debug, Default)]
struct HlodStats {
    not_coarser: u64,
    vanished: u64,
}

/// The coarsest representations under group `id`: per child its HLOD or coarsest LOD, or, for
/// a child group without an HLOD, its own children's, recursively. `below[k - offset]` holds
/// the HLOD of group k.
fn coarse_parts<'a>(
    tree: &[bvh::BvhNode],
    chains: &'a [Vec<Level>],
    below: &'a [Option<Level>],
    offset: usize,
    id: usize,
    parts: &mut Vec<&'a Level>,
) {
    for c in tree[id].children.clone() {
        let c = c as usize;
        match (tree[c].item, &below[c - offset]) {
            (Some(chunk), _) => parts.push(chains[chunk as usize].last().expect("level 0")),
            (None, Some(h)) => parts.push(h),
            (None, None) => coarse_parts(tree, chains, below, offset, c, parts),
        }
    }
}

/// Numbers LOD nodes after the BVH nodes (each BVH node's LODs contiguous, finest first) and
/// fills in the records.
fn assemble(
    tree: &[bvh::BvhNode],
    chunks: &[(u32, Mesh)],
    chains: Vec<Vec<Level>>,
    hlods: Vec<Option<Level>>,
    origin: [f64; 3],
    report: &mut BuildReport,
) -> SceneData {
    let bvh_count = tree.len() as u32;
    let mut nodes: Vec<NodeRecord> = Vec::with_capacity(tree.len() * 3);
    let mut lods: Vec<NodeRecord> = Vec::new();
    let mut blocks: Vec<Mesh> = Vec::new();
    let mut chains: Vec<Option<Vec<Level>>> = chains.into_iter().map(Some).collect();
    let mut hlods = hlods;
    for (id, n) in tree.iter().enumerate() {
        let levels: Vec<Level> = match n.item {
            Some(chunk) => chains[chunk as usize].take().expect("each chunk in one leaf"),
            None => hlods[id].take().into_iter().collect(),
        };
        let object = n.item.map_or(NONE, |c| chunks[c as usize].0);
        let first_lod = bvh_count + lods.len() as u32;
        for l in &levels {
            let b = l.mesh.bounds();
            lods.push(NodeRecord {
                bbox_min: b.min.into(),
                kind: NodeKind::Lod as u32,
                bbox_max: b.max.into(),
                error: l.error,
                parent: id as u32,
                first_child: 0,
                child_count: 0,
                first_lod: 0,
                lod_count: 0,
                block: lods.len() as u32,
                object,
                triangles: l.mesh.triangle_count() as u32,
            });
        }
        report.lod_levels_max = report.lod_levels_max.max(if n.item.is_some() { levels.len() as u64 } else { 0 });
        if n.item.is_none() && !levels.is_empty() {
            report.hlod_nodes += 1;
        }
        let error = levels.first().map_or(0.0, |l| l.error);
        blocks.extend(levels.into_iter().map(|l| l.mesh));
        nodes.push(NodeRecord {
            bbox_min: n.bounds.min.into(),
            kind: if n.item.is_some() { NodeKind::Leaf } else { NodeKind::Group } as u32,
            bbox_max: n.bounds.max.into(),
            error,
            parent: n.parent.unwrap_or(NONE),
            first_child: if n.children.is_empty() { 0 } else { n.children.start },
            child_count: n.children.len() as u32,
            first_lod,
            lod_count: (bvh_count + lods.len() as u32) - first_lod,
            block: NONE,
            object,
            triangles: n.item.map_or(0, |c| chunks[c as usize].1.triangle_count() as u32),
        });
    }
    // Bottom-up (children have larger ids): subtree triangles, and the error of a group
    // without an HLOD (the largest of its children's, so errors never decrease going up).
    for id in (0..tree.len()).rev() {
        let n = nodes[id];
        if n.kind() == NodeKind::Group {
            let triangles = n.children().map(|c| nodes[c as usize].triangles).sum();
            let children_error = n.children().map(|c| nodes[c as usize].error).fold(0.0, f32::max);
            nodes[id].triangles = triangles;
            if n.lod_count == 0 {
                nodes[id].error = children_error;
            }
        }
    }
    report.leaves = tree.iter().filter(|n| n.item.is_some()).count() as u64;
    report.groups = tree.len() as u64 - report.leaves;
    report.lod_nodes = lods.len() as u64;
    report.stored_triangles = lods.iter().map(|l| l.triangles as u64).sum();
    let leaf_triangles = nodes[0].triangles;
    nodes.extend(lods);
    report.nodes = nodes.len() as u64;
    SceneData {
        origin,
        bvh_count,
        leaf_count: report.leaves as u32,
        object_count: report.objects as u32,
        leaf_triangles,
        nodes,
        blocks,
        closed_objects: Vec::new(),
    }
}

fn report_left_out(report: &mut BuildReport, lod: &LodStats, hlod: &HlodStats, groups: u64) {
    let l = crate::limits::LOD_MIN_TRIANGLES;
    if lod.too_small > 0 {
        report
            .left_out
            .push(format!("LODs of {} chunks of at most {l} triangles: a coarser level would save almost nothing", lod.too_small));
    }
    if lod.not_paying > 0 {
        let cut = ((1.0 - crate::limits::LOD_MIN_REDUCTION) * 100.0).round();
        report.left_out.push(format!(
            "{} LOD levels that cut fewer than {cut}% of the previous level's triangles (the end of each such chain)",
            lod.not_paying
        ));
    }
    if hlod.not_coarser > 0 {
        let keep = (crate::limits::HLOD_MAX_FRACTION * 100.0).round();
        report.left_out.push(format!("HLODs of {} of {groups} interior nodes: simplification kept more than {keep}% of the children's triangles, so drawing the children costs little more", hlod.not_coarser));
    }
    if hlod.vanished > 0 {
        report.left_out.push(format!("HLODs of {} of {groups} interior nodes: the children's coarsest levels are too small to merge into anything coarser; the parent's HLOD covers them", hlod.vanished));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;
    use glam::Vec3;

    #[test]
    fn empty_input_is_an_error_naming_why() {
        let o = Object::new("nothing", Mesh::default());
        let e = make_scene(vec![o], &BuildOptions::default(), &mut BuildReport::default(), &()).unwrap_err();
        assert!(e.to_string().contains("empty scene"), "{e}");
    }

    #[test]
    fn bad_object_is_named() {
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        m.positions[3][0] = f32::INFINITY;
        let e = make_scene(vec![Object::new("boxy", m)], &BuildOptions::default(), &mut BuildReport::default(), &()).unwrap_err();
        assert!(e.to_string().contains("object 0 (boxy)") && e.to_string().contains("non-finite"), "{e}");
    }

    #[test]
    fn one_box_is_one_leaf_with_one_lod() {
        // Expected: node 0 = the leaf, node 1 = its only LOD (12 triangles, too small to simplify).
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        let mut report = BuildReport::default();
        let s = make_scene(vec![Object::new("b", m)], &BuildOptions::default(), &mut report, &()).unwrap();
        assert_eq!(s.bvh_count, 1);
        assert_eq!(s.nodes.len(), 2);
        assert_eq!(s.nodes[0].kind(), NodeKind::Leaf);
        assert_eq!(s.nodes[0].lods(), 1..2);
        assert_eq!(s.nodes[1].triangles, 12);
        assert!(report.left_out.iter().any(|l| l.contains("LODs of 1 chunks")));
    }
}
