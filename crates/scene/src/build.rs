//! The scene build, out of core: its peak memory is one batch of the input or one subtree of
//! the model plus the tables, whatever the model's size (occlusion switch sec. 4.1 for what it makes).
//!
//! 1. Stream ([`crate::stream`]): the source's batches → placement around one origin →
//!    clean-up → chunks, appended to a spill file beside the output.
//! 2. The BVH over all chunk boxes ([`crate::bvh`]; a box per few thousand triangles).
//! 3. Subtrees of at most `bucket_triangles` input triangles, in depth-first order
//!    ([`crate::subtree`]): their chunks read back, LOD chains, HLODs, blocks encoded and
//!    appended to the scene file. Of a subtree only its root's coarsest representation stays.
//! 4. The groups above the subtrees: their HLODs from those representations.
//! 5. The node and block tables after the blob, then the header ([`crate::writer`]).
//!
//! The node table and every block do not depend on the bucket size; only the order of the
//! blocks in the file does (a test builds one model both ways).

use crate::aabb::Aabb;
use crate::format::NodeRecord;
use crate::lod::LodStats;
use crate::mesh::{MeshError, Object};
use crate::source::{InMemory, Source};
use crate::subtree::Built;
use crate::writer::{SceneFields, SceneWriter};
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
    /// Most input triangles built in memory at once (see [`crate::limits::BUCKET_TRIANGLES`]).
    pub bucket_triangles: u64,
    /// Static LOD chains per chunk, or a cluster hierarchy per object.
    pub lod: Lod,
    /// A mesh that the input uses several times: stored once, or a copy per use.
    pub instances: Instances,
    /// Look for objects whose mesh repeats an earlier one's up to a translation where the
    /// input does not say so ([`crate::repeat`]): on for files, off for the generators, whose
    /// scenes stay as every earlier figure measured them (the plain plant repeats its
    /// walkways and railings bay to bay: 13,351 objects of the 20M plant would be found).
    pub find_repeats: bool,
}

/// What the build does with a mesh the input uses several times (a glTF mesh of several nodes,
/// EXT_mesh_gpu_instancing). Both clean and cut it in its own frame and build its LOD chains
/// once; `Expand` then writes each use's copy, placed, where `Keep` writes the use's transform.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Instances {
    #[default]
    Keep,
    Expand,
}

impl std::str::FromStr for Instances {
    type Err = String;

    fn from_str(s: &str) -> Result<Instances, String> {
        match s {
            "keep" => Ok(Instances::Keep),
            "expand" => Ok(Instances::Expand),
            _ => Err(format!("{s:?}: expected keep or expand")),
        }
    }
}

/// How a scene's detail is reduced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lod {
    /// A chain of levels per chunk, borders locked, chosen whole (occlusion switch sec. 4.1).
    #[default]
    Chains,
    /// A cluster hierarchy per object whose detail varies across a surface ([`crate::clod`]).
    Clusters,
}

impl std::str::FromStr for Lod {
    type Err = String;

    fn from_str(s: &str) -> Result<Lod, String> {
        match s {
            "chains" => Ok(Lod::Chains),
            "clusters" => Ok(Lod::Clusters),
            _ => Err(format!("{s:?}: expected chains or clusters")),
        }
    }
}

impl std::fmt::Display for Lod {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(if *self == Lod::Chains { "chains" } else { "clusters" })
    }
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            chunk_triangles: crate::limits::CHUNK_TRIANGLES,
            loose_split: crate::limits::LOOSE_SPLIT,
            model_colors: true,
            bucket_triangles: crate::limits::BUCKET_TRIANGLES,
            lod: Lod::Chains,
            instances: Instances::Keep,
            find_repeats: false,
        }
    }
}

/// Progress of a long build, reported per stage, and whether the user asked to stop. `()`
/// reports nothing and never stops.
pub trait Progress: Sync {
    fn stage(&self, name: &str, total: u64);
    fn advance(&self, n: u64);
    fn cancelled(&self) -> bool {
        false
    }
}

impl Progress for () {
    fn stage(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
}

/// What the build made, written next to the scene as `<scene>.build.json`.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
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
    /// Triangles with a translucent colour, and the objects that have any: drawn blended after
    /// the opaque ones, never occluders (see [`crate::format::BlockRecord::opaque_clusters`]).
    pub translucent_triangles: u64,
    pub translucent_objects: u64,
    pub nodes: u64,
    pub leaves: u64,
    pub groups: u64,
    pub lod_nodes: u64,
    pub lod_levels_max: u64,
    /// `chains` or `clusters`.
    pub lod: String,
    /// Levels of simplification of the deepest cluster hierarchy, the simplified groups and
    /// the pieces their clusters leave in, one per chunk each lies in (0 with chains).
    pub cluster_levels_max: u64,
    pub simplified_groups: u64,
    pub simplified_pieces: u64,
    /// Triangles dropped from simplified groups as fins ([`crate::fins`]).
    #[serde(default)]
    pub fin_triangles_dropped: u64,
    /// Cut nodes: BVH nodes' parts of the cluster hierarchies.
    pub cut_nodes: u64,
    pub hlod_nodes: u64,
    /// Triangles stored over all LOD and HLOD blocks.
    pub stored_triangles: u64,
    pub degenerate_triangles_dropped: u64,
    /// Repeats: the input's triangles with each mesh that the input says several objects use
    /// (a glTF mesh of several nodes, EXT_mesh_gpu_instancing) counted once, after clean-up;
    /// the triangles of those objects, and how many they are.
    #[serde(default)]
    pub unique_triangles: u64,
    #[serde(default)]
    pub instanced_triangles: u64,
    #[serde(default)]
    pub instances: u64,
    /// Of those, the objects found to repeat an earlier object's mesh up to a translation,
    /// where the input did not say so ([`crate::repeat`]).
    #[serde(default)]
    pub found_repeats: u64,
    /// Meshes stored once (`--instances keep`), and the bytes of geometry blocks their uses
    /// share instead of storing a copy each.
    #[serde(default)]
    pub prototypes: u64,
    #[serde(default)]
    pub bytes_saved: u64,
    pub output_bytes: u64,
    pub content_hash: String,
    pub seconds: f64,
    pub input_triangles_per_second: f64,
    /// Peak resident memory of the building process (KiB; set by the caller, 0 if unknown).
    pub peak_rss_kb: u64,
    /// Most temporary disk the build used (the spill file of chunks), bytes.
    pub temp_bytes: u64,
    /// Subtrees built one at a time, and the most input triangles in one.
    pub buckets: u64,
    pub bucket_triangles: u64,
    /// Seconds per stage, summed over batches and subtrees.
    pub stage_seconds: BTreeMap<String, f64>,
    /// What the build left out and why.
    pub left_out: Vec<String>,
    pub notes: Vec<String>,
}

/// Seconds per stage, summed over every time a stage runs.
#[derive(Default)]
pub struct Times(BTreeMap<String, f64>);

impl Times {
    pub fn run<T>(&mut self, stage: &str, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let r = f();
        *self.0.entry(stage.to_owned()).or_default() += t.elapsed().as_secs_f64();
        r
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("object {index} ({name}): {source}")]
    Mesh { index: usize, name: String, source: MeshError },
    #[error("empty scene: {0}")]
    Empty(String),
    #[error("scene too large: {0}")]
    TooLarge(String),
    #[error("{path}: {error}")]
    Write { path: String, error: std::io::Error },
    #[error("temporary file {path}: {error}")]
    Temp { path: String, error: std::io::Error },
    #[error("interrupted: the partial scene and the temporary files were removed")]
    Interrupted,
}

impl BuildError {
    pub(crate) fn temp(path: &Path, source: std::io::Error) -> BuildError {
        BuildError::Temp { path: path.display().to_string(), error: source }
    }
}

/// Builds the scene from objects in memory (see [`build`]).
pub fn build_scene(
    objects: Vec<Object>,
    input: &str,
    notes: Vec<String>,
    opts: &BuildOptions,
    out: &Path,
    started: Instant,
    progress: &dyn Progress,
) -> Result<BuildReport, BuildError> {
    build(&mut InMemory::new(objects), input, notes, opts, out, started, progress)
}

/// Builds the scene from `source` and writes it to `out`. `input` names the source in the
/// report; `notes` go into the report as they are. `started` is when reading the input began:
/// the report's times are end to end.
pub fn build(
    source: &mut dyn Source,
    input: &str,
    notes: Vec<String>,
    opts: &BuildOptions,
    out: &Path,
    started: Instant,
    progress: &dyn Progress,
) -> Result<BuildReport, BuildError> {
    let mut report = BuildReport { input: input.to_owned(), notes, lod: opts.lod.to_string(), ..Default::default() };
    let mut times = Times::default();
    times.0.insert("input".into(), started.elapsed().as_secs_f64());
    let s = crate::stream::stream(source, opts, out, &mut report, &mut times, progress)?;
    let scene_box = s.chunks.iter().fold(Aabb::EMPTY, |b, c| b.union(c.bounds));
    let min_error = (crate::limits::MIN_RELATIVE_ERROR * scene_box.extent().length()).max(f32::MIN_POSITIVE);

    progress.stage("bvh", 1);
    let boxes: Vec<Aabb> = s.chunks.iter().map(|c| c.bounds).collect();
    let tree = times.run("bvh", || crate::bvh::build(&boxes));
    drop(boxes);
    let lod_ids_max = 2 * tree.len() as u64 + s.chunks.len() as u64 * crate::limits::LOD_MAX_LEVELS as u64;
    if lod_ids_max > crate::limits::MAX_NODES as u64 {
        return Err(BuildError::TooLarge(format!("{} chunks need more than 2^32 node ids", s.chunks.len())));
    }
    let subtree_triangles = subtree_triangles(&tree, &s.chunks);
    let buckets = buckets(&tree, &subtree_triangles, opts.bucket_triangles.max(1));
    report.buckets = buckets.len() as u64;
    report.bucket_triangles = buckets.iter().map(|b| b.iter().map(|&r| subtree_triangles[r as usize]).sum::<u64>()).max().unwrap_or(0);

    let owners = match opts.lod {
        // Chains lock every chunk border: an HLOD over part of an object meets the rest of it.
        Lod::Chains => crate::owner::Owners { owned: Vec::new(), open: vec![false; tree.len()] },
        Lod::Clusters => times.run("bvh", || crate::owner::owners(&tree, &s.chunks, (&s.coarse, &s.coarse_chunk), s.closed_objects.len())),
    };

    let mut writer = SceneWriter::create(out).map_err(|e| BuildError::Write { path: out.display().to_string(), error: e })?;
    let mut built =
        Built::new(&tree, &s.chunks, &s.closed_objects, min_error, (opts.lod, opts.instances), &owners, (&s.prototypes, &s.instances));
    // Each prototype's part is read and built in the first bucket that places it.
    let mut first_bucket = vec![u32::MAX; s.prototypes.parts.len()];
    for (k, bucket) in buckets.iter().enumerate() {
        for id in crate::subtree::layers(&tree, bucket, |_| false).into_iter().flatten() {
            if let Some(c) = tree[id as usize].item.map(|c| &s.chunks[c as usize]).filter(|c| c.part != crate::format::NONE) {
                first_bucket[c.part as usize] = first_bucket[c.part as usize].min(k as u32);
            }
        }
    }
    progress.stage("build", subtree_triangles[0]);
    // While a bucket is built on both cores, a thread reads the next one's chunks from the spill
    // (which no longer fits the page cache at 1B triangles, so reads wait for the disk).
    let read = |k: usize| {
        crate::subtree::read(&tree, &s.chunks, (&s.coarse, &owners.owned), &s.spill, &buckets[k], |part| {
            first_bucket[part as usize] == k as u32
        })
    };
    std::thread::scope(|scope| -> Result<(), BuildError> {
        let mut next = Some(scope.spawn(move || read(0)));
        for k in 0..buckets.len() {
            let bucket = times.run("spill", || next.take().expect("read ahead").join().expect("the spill reader does not panic"));
            let bucket = bucket.map_err(|e| BuildError::temp(s.spill.path(), e))?;
            if progress.cancelled() {
                return Err(BuildError::Interrupted);
            }
            next = (k + 1 < buckets.len()).then(|| scope.spawn(move || read(k + 1)));
            built.subtrees(bucket, &mut writer, &mut times, progress)?;
            if k % SUBTREES_PER_TRIM == SUBTREES_PER_TRIM - 1 {
                return_freed_memory();
            }
        }
        Ok(())
    })?;
    // The groups above the subtrees, deepest first.
    let roots: std::collections::HashSet<u32> = buckets.iter().flatten().copied().collect();
    if !roots.contains(&0) {
        for layer in crate::subtree::layers(&tree, &[0], |id| roots.contains(&id)).iter().rev() {
            let owned =
                crate::subtree::read_owned(layer, (&s.coarse, &owners.owned), &s.spill).map_err(|e| BuildError::temp(s.spill.path(), e))?;
            built.groups(layer, owned, &mut writer, &mut times)?;
        }
    }
    drop(s.spill);

    progress.stage("tables", 1);
    let (bvh, lods) = times.run("tables", || built.tables(&mut report));
    let fields = SceneFields {
        origin: s.origin.to_array(),
        bvh_count: tree.len() as u32,
        object_count: report.objects as u32,
        leaf_count: report.leaves as u32,
        leaf_triangles: bvh[0].triangles,
    };
    let (bytes, hash) = times
        .run("write", || writer.finish(fields, &bvh, &lods, if opts.instances == Instances::Keep { &s.instances } else { &[] }))
        .map_err(|e| BuildError::Write { path: out.display().to_string(), error: e })?;
    report.output_bytes = bytes;
    report.content_hash = crate::format::hash_hex(hash);
    report.stage_seconds = times.0;
    report.seconds = started.elapsed().as_secs_f64();
    report.input_triangles_per_second = report.input_triangles as f64 / report.seconds.max(1e-9);
    Ok(report)
}

/// Subtrees built between two hand-backs of freed memory to the kernel. glibc keeps the pages
/// a subtree's meshes freed in its heaps while a smaller allocation that outlives the subtree
/// (an LOD record, the coarsest level its parent merges) sits above them, so the resident
/// memory grew with the model. A hand-back after every subtree costs time (the pages are
/// taken again) for little lower a peak than one every 16th
/// (docs/measurements/2026-12-05-instances-sweep-memory.md, "The 10B build's memory").
const SUBTREES_PER_TRIM: usize = 16;

fn return_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory of the heaps; any argument is valid.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Input triangles under each BVH node (children have larger ids than their parent).
fn subtree_triangles(tree: &[crate::bvh::BvhNode], chunks: &[crate::stream::Chunk]) -> Vec<u64> {
    let mut t = vec![0u64; tree.len()];
    for id in (0..tree.len()).rev() {
        t[id] = match tree[id].item {
            Some(c) => chunks[c as usize].triangles as u64,
            None => tree[id].children.clone().map(|c| t[c as usize]).sum(),
        };
    }
    t
}

/// The subtrees built one at a time: the highest nodes with at most `most` triangles under
/// them (or single leaves), in depth-first order, and consecutive small ones put together up
/// to `most`.
fn buckets(tree: &[crate::bvh::BvhNode], triangles: &[u64], most: u64) -> Vec<Vec<u32>> {
    let mut out: Vec<Vec<u32>> = Vec::new();
    let mut filling = 0u64;
    let mut stack = vec![0u32];
    while let Some(id) = stack.pop() {
        let n = &tree[id as usize];
        let t = triangles[id as usize];
        if t <= most || n.item.is_some() {
            match out.last_mut() {
                Some(b) if filling + t <= most => b.push(id),
                _ => {
                    out.push(vec![id]);
                    filling = 0;
                }
            }
            filling += t;
        } else {
            stack.extend(n.children.clone().rev());
        }
    }
    out
}

/// The node table of `objects` built with `opts`, through a temporary file: for tests and
/// benches that need a real hierarchy without a GPU.
pub fn node_table(objects: Vec<Object>, opts: &BuildOptions) -> Result<Vec<NodeRecord>, BuildError> {
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let path = std::env::temp_dir().join(format!("osw-node-table-{}-{k}.osw", std::process::id()));
    build_scene(objects, "node table", Vec::new(), opts, &path, Instant::now(), &())?;
    let nodes = crate::SceneFile::open(&path).map(|f| f.nodes().to_vec());
    let _ = std::fs::remove_file(&path);
    nodes.map_err(|e| BuildError::Write { path: path.display().to_string(), error: std::io::Error::other(e.to_string()) })
}

pub(crate) fn report_left_out(report: &mut BuildReport, lod: &LodStats, [not_coarser, vanished, open]: [u64; 3]) {
    let l = crate::limits::LOD_MIN_TRIANGLES;
    let groups = report.groups;
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
    if not_coarser > 0 {
        let keep = (crate::limits::HLOD_MAX_FRACTION * 100.0).round();
        report.left_out.push(format!("HLODs of {not_coarser} of {groups} interior nodes: simplification kept more than {keep}% of the children's triangles, so drawing the children costs little more"));
    }
    if open > 0 {
        report.left_out.push(format!("HLODs of {open} of {groups} interior nodes: an object under each reaches outside it, and its cluster hierarchy is the coarser representation there"));
    }
    if vanished > 0 {
        report.left_out.push(format!("HLODs of {vanished} of {groups} interior nodes: the children's coarsest levels are too small to merge into anything coarser; the parent's HLOD covers them"));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::NodeKind;
    use crate::generators::shapes;
    use crate::mesh::Mesh;
    use glam::Vec3;

    #[test]
    fn empty_input_is_an_error_naming_why() {
        let o = Object::new("nothing", Mesh::default());
        let e = node_table(vec![o], &BuildOptions::default()).unwrap_err();
        assert!(e.to_string().contains("empty scene"), "{e}");
    }

    #[test]
    fn bad_object_is_named() {
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        m.positions[3][0] = f32::INFINITY;
        let ok = |name: &str| {
            Object::new(name, {
                let mut m = Mesh::default();
                shapes::add_box(&mut m, Vec3::ZERO, Vec3::ONE);
                m
            })
        };
        let e = node_table(vec![ok("a"), ok("b"), Object::new("boxy", m)], &BuildOptions::default()).unwrap_err();
        assert!(e.to_string().contains("object 2 (boxy)") && e.to_string().contains("non-finite"), "{e}");
    }

    #[test]
    fn one_box_is_one_leaf_with_one_lod() {
        // Expected: node 0 = the leaf, node 1 = its only LOD (12 triangles, too small to simplify).
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        let nodes = node_table(vec![Object::new("b", m)], &BuildOptions::default()).unwrap();
        assert_eq!(nodes.len(), 2);
        assert_eq!(nodes[0].kind(), NodeKind::Leaf);
        assert_eq!(nodes[0].lods(), 1..2);
        assert_eq!(nodes[1].triangles, 12);
    }

    /// Two input meshes of one content are one prototype, and a later use may come without
    /// its mesh: three uses of a box, stored once, each leaf's geometry the box moved.
    #[test]
    fn meshes_of_one_content_are_one_prototype_placed_per_use() {
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        let at = |prototype, mesh: &Mesh, x: f64| Object {
            prototype: Some(prototype),
            ..Object::placed("box", mesh.clone(), glam::DVec3::ZERO, glam::DAffine3::from_translation(glam::DVec3::new(x, 0.0, 0.0)))
        };
        let objects = vec![at(0, &m, 0.0), at(1, &m, 5.0), at(0, &Mesh::default(), 10.0)];
        let path = std::env::temp_dir().join(format!("osw-prototypes-{}.osw", std::process::id()));
        let r = build_scene(objects, "boxes", Vec::new(), &BuildOptions::default(), &path, Instant::now(), &()).unwrap();
        assert_eq!((r.prototypes, r.instances, r.unique_triangles, r.input_triangles), (1, 3, 12, 36), "{r:?}");
        let scene = crate::SceneFile::open(&path).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(scene.instances().len(), 3);
        let (o, mut xs) = (scene.origin(), Vec::new());
        for leaf in scene.nodes().iter().filter(|n| n.kind() == NodeKind::Leaf) {
            let g = scene.geometry(leaf.first_lod).unwrap();
            let mut world: Vec<[f64; 3]> = g.positions.iter().map(|p| (o + Vec3::from_array(*p).as_dvec3()).to_array()).collect();
            let x = world.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
            let mut want: Vec<[f64; 3]> = m.positions.iter().map(|p| [p[0] as f64 + x, p[1] as f64, p[2] as f64]).collect();
            world.sort_by(|a, b| a.partial_cmp(b).unwrap());
            want.sort_by(|a, b| a.partial_cmp(b).unwrap());
            assert_eq!(world, want, "the leaf at x {x}");
            xs.push(x);
        }
        xs.sort_by(f64::total_cmp);
        assert_eq!(xs, [0.0, 5.0, 10.0]);
    }

    #[test]
    fn buckets_cover_every_leaf_once_in_depth_first_order() {
        let boxes: Vec<Aabb> = (0..50).map(|i| Aabb::new(Vec3::splat(i as f32), Vec3::splat(i as f32 + 0.5))).collect();
        let tree = crate::bvh::build(&boxes);
        let triangles: Vec<u64> = {
            let mut t = vec![0u64; tree.len()];
            for id in (0..tree.len()).rev() {
                t[id] = match tree[id].item {
                    Some(i) => 10 + i as u64,
                    None => tree[id].children.clone().map(|c| t[c as usize]).sum(),
                };
            }
            t
        };
        for most in [1, 30, 100, 400, u64::MAX] {
            let b = buckets(&tree, &triangles, most);
            let roots: Vec<u32> = b.iter().flatten().copied().collect();
            let mut leaves: Vec<u32> =
                crate::subtree::layers(&tree, &roots, |_| false).into_iter().flatten().filter_map(|id| tree[id as usize].item).collect();
            leaves.sort();
            assert_eq!(leaves, (0..50).collect::<Vec<_>>(), "most {most}");
            for bucket in &b {
                let t: u64 = bucket.iter().map(|&r| triangles[r as usize]).sum();
                assert!(t <= most || bucket.len() == 1, "most {most}: bucket of {t}");
            }
        }
        assert_eq!(buckets(&tree, &triangles, u64::MAX), vec![vec![0]]);
    }
}
