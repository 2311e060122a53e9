//! The scene build, out of core: its peak memory is one batch of the input or one subtree of
//! the model plus the tables, whatever the model's size (occlusion switch sec. 4.1 for what it makes).
//!
//! 1. Stream ([`stream`]): the source's batches → placement around one origin →
//!    clean-up → chunks, appended to a spill file beside the output.
//! 2. The BVH over all chunk boxes ([`crate::bvh`]; a box per few thousand triangles).
//! 3. Subtrees of at most `bucket_triangles` input triangles, in depth-first order
//!    ([`subtree`]): their chunks read back, LOD chains, HLODs, blocks encoded and
//!    appended to the scene file. Of a subtree only its root's coarsest representation stays.
//! 4. The groups above the subtrees: their HLODs from those representations.
//! 5. The node and block tables after the blob, then the header ([`crate::writer`]).
//!
//! The node table and every block do not depend on the bucket size; only the order of the
//! blocks in the file does (a test builds one model both ways).

mod error;
mod options;
mod owner;
mod report;
mod stream;
mod subtree;

pub use error::BuildError;
pub use options::{BuildOptions, Instances, Lod};
pub use report::{BuildReport, Times};

use crate::aabb::Aabb;
use crate::bvh::BvhNode;
use crate::format::{BlockRecord, NodeRecord};
use crate::mesh::Object;
use crate::progress::Progress;
use crate::source::{InMemory, Source};
use crate::writer::{SceneFields, SceneWriter};
use owner::Owners;
use std::path::Path;
use std::time::Instant;
use stream::{Chunked, Streamed};
use subtree::Built;

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
    let normals = opts.normals.to_string();
    let mut report = BuildReport { input: input.to_owned(), notes, lod: opts.lod.to_string(), normals, ..Default::default() };
    let mut times = Times::default();
    times.0.insert("input".into(), started.elapsed().as_secs_f64());
    let s = stream::stream(source, opts, out, &mut report, &mut times, progress)?;
    let c = &s.chunked;
    let plan = Plan::of(c, opts, &mut report, &mut times, progress)?;
    let scene_box = c.chunks.iter().fold(Aabb::EMPTY, |b, c| b.union(c.bounds));
    let min_error = (crate::limits::MIN_RELATIVE_ERROR * scene_box.extent().length()).max(f32::MIN_POSITIVE);
    let mut writer = SceneWriter::create(out).map_err(|e| BuildError::Write { path: out.display().to_string(), source: e })?;
    let mut built = Built::new(&plan.tree, c, &plan.owners, min_error, opts);
    progress.stage("build", plan.subtree_triangles[0]);
    build_subtrees(&plan, &s, &mut built, &mut writer, &mut times, progress)?;
    build_groups(&plan, &s, &mut built, &mut writer, &mut times)?;
    drop(s.spill);

    progress.stage("tables", 1);
    let (bvh, lods) = times.run("tables", || built.tables(&mut report));
    let fields = SceneFields {
        origin: c.origin.to_array(),
        bvh_count: plan.tree.len() as u32,
        object_count: report.objects as u32,
        leaf_count: report.leaves as u32,
        leaf_triangles: bvh[0].triangles,
    };
    let mut stored = rustc_hash::FxHashSet::default();
    let distinct = lods.iter().filter(|(_, b)| stored.insert(b.offset));
    let distinct: Vec<&BlockRecord> = distinct.map(|(_, b)| b).collect();
    report.normal_bytes = distinct.iter().map(|b| b.vertex_count as u64 * b.normal_bytes as u64).sum();
    report.texcoord_bytes = distinct.iter().map(|b| b.vertex_count as u64 * b.texcoord_bytes as u64).sum();
    let textures = source.textures();
    (report.images, report.textures) = (textures.images.len() as u64, textures.textures.len() as u64);
    let instances = if opts.instances == Instances::Keep { &c.instances[..] } else { &[] };
    let (bytes, hash) = times
        .run("write", || writer.finish(fields, &bvh, &lods, instances, &textures))
        .map_err(|e| BuildError::Write { path: out.display().to_string(), source: e })?;
    report.texel_bytes =
        textures.images.iter().map(|i| crate::mip::base_size(i.width, i.height)).map(|(w, h)| crate::mip::chain_bytes(w, h)).sum();
    report.output_bytes = bytes;
    report.content_hash = crate::format::hash_hex(hash);
    report.stage_seconds = times.0;
    report.seconds = started.elapsed().as_secs_f64();
    report.input_triangles_per_second = report.input_triangles as f64 / report.seconds.max(1e-9);
    Ok(report)
}

/// The BVH over the chunks and how it is built: the subtrees of each bucket, and who owns the
/// simplified pieces of cluster hierarchies.
struct Plan {
    tree: Vec<BvhNode>,
    subtree_triangles: Vec<u64>,
    buckets: Vec<Vec<u32>>,
    owners: Owners,
    /// Per prototype part: the first bucket that places it (its part is read and built there).
    first_bucket: Vec<u32>,
}

impl Plan {
    fn of(
        c: &Chunked,
        opts: &BuildOptions,
        report: &mut BuildReport,
        times: &mut Times,
        progress: &dyn Progress,
    ) -> Result<Plan, BuildError> {
        progress.stage("bvh", 1);
        let boxes: Vec<Aabb> = c.chunks.iter().map(|c| c.bounds).collect();
        let tree = times.run("bvh", || crate::bvh::build(&boxes));
        drop(boxes);
        let lod_ids_max = 2 * tree.len() as u64 + c.chunks.len() as u64 * crate::limits::LOD_MAX_LEVELS as u64;
        if lod_ids_max > crate::limits::MAX_NODES as u64 {
            return Err(BuildError::TooLarge(format!("{} chunks need more than 2^32 node ids", c.chunks.len())));
        }
        let subtree_triangles = subtree_triangles(&tree, &c.chunks);
        let buckets = buckets(&tree, &subtree_triangles, opts.bucket_triangles.max(1));
        report.buckets = buckets.len() as u64;
        report.bucket_triangles = buckets.iter().map(|b| b.iter().map(|&r| subtree_triangles[r as usize]).sum::<u64>()).max().unwrap_or(0);
        let owners = match opts.lod {
            // Chains lock every chunk border: an HLOD over part of an object meets the rest of it.
            Lod::Chains => Owners { owned: Vec::new(), open: vec![false; tree.len()] },
            Lod::Clusters => times.run("bvh", || owner::owners(&tree, c)),
        };
        let mut first_bucket = vec![u32::MAX; c.prototypes.parts.len()];
        for (k, bucket) in buckets.iter().enumerate() {
            for id in subtree::layers(&tree, bucket, |_| false).into_iter().flatten() {
                if let Some(c) = tree[id as usize].item.map(|k| &c.chunks[k as usize]).filter(|c| c.part != crate::format::NONE) {
                    first_bucket[c.part as usize] = first_bucket[c.part as usize].min(k as u32);
                }
            }
        }
        Ok(Plan { tree, subtree_triangles, buckets, owners, first_bucket })
    }
}

/// Builds the buckets' subtrees in turn. While a bucket is built on both cores, a thread reads
/// the next one's chunks from the spill (which no longer fits the page cache at a billion
/// triangles, so reads wait for the disk).
fn build_subtrees(
    plan: &Plan,
    s: &Streamed,
    built: &mut Built,
    writer: &mut SceneWriter,
    times: &mut Times,
    progress: &dyn Progress,
) -> Result<(), BuildError> {
    let read = |k: usize| {
        subtree::read(&plan.tree, &s.chunked, &plan.owners.owned, &s.spill, &plan.buckets[k], |part| {
            plan.first_bucket[part as usize] == k as u32
        })
    };
    std::thread::scope(|scope| -> Result<(), BuildError> {
        let mut next = Some(scope.spawn(move || read(0)));
        for k in 0..plan.buckets.len() {
            let bucket = times.run("spill", || next.take().expect("read ahead").join().expect("the spill reader does not panic"));
            let bucket = bucket.map_err(|e| BuildError::temp(s.spill.path(), e))?;
            if progress.cancelled() {
                return Err(BuildError::Interrupted);
            }
            next = (k + 1 < plan.buckets.len()).then(|| scope.spawn(move || read(k + 1)));
            built.subtrees(bucket, writer, times, progress)?;
            if k % SUBTREES_PER_TRIM == SUBTREES_PER_TRIM - 1 {
                return_freed_memory();
            }
        }
        Ok(())
    })
}

/// Builds the groups above the buckets' subtrees, deepest first.
fn build_groups(plan: &Plan, s: &Streamed, built: &mut Built, writer: &mut SceneWriter, times: &mut Times) -> Result<(), BuildError> {
    let roots: std::collections::HashSet<u32> = plan.buckets.iter().flatten().copied().collect();
    if roots.contains(&0) {
        return Ok(());
    }
    for layer in subtree::layers(&plan.tree, &[0], |id| roots.contains(&id)).iter().rev() {
        let owned =
            subtree::read_owned(layer, &s.chunked.coarse, &plan.owners.owned, &s.spill).map_err(|e| BuildError::temp(s.spill.path(), e))?;
        built.groups(layer, owned, writer, times)?;
    }
    Ok(())
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
fn subtree_triangles(tree: &[BvhNode], chunks: &[stream::Chunk]) -> Vec<u64> {
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
fn buckets(tree: &[BvhNode], triangles: &[u64], most: u64) -> Vec<Vec<u32>> {
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
    nodes.map_err(|e| BuildError::Write { path: path.display().to_string(), source: std::io::Error::other(e.to_string()) })
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
        // The object, then its mesh's fault as the error's source.
        let chain: Vec<String> = std::iter::successors(Some(&e as &dyn std::error::Error), |e| e.source()).map(|e| e.to_string()).collect();
        assert!(chain[0] == "object 2 (boxy)" && chain[1].contains("non-finite"), "{chain:?}");
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
                subtree::layers(&tree, &roots, |_| false).into_iter().flatten().filter_map(|id| tree[id as usize].item).collect();
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
