//! What a build reports: what it made, how long each stage took, and what it left out.

use crate::lod::LodStats;
use std::collections::BTreeMap;
use std::time::Instant;

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
    /// Triangles of cut-outs, and the objects that have any: drawn opaque, never occluders (see
    /// [`crate::mesh::CUT_OUT`]).
    pub cut_out_triangles: u64,
    pub cut_out_objects: u64,
    /// How surfaces are shaded: "flat", or "smooth, creases at N°" ([`crate::smooth::Normals`]).
    #[serde(default)]
    pub normals: String,
    /// Objects whose model gives normals (the rest are computed, or none are stored: flat).
    #[serde(default)]
    pub objects_with_model_normals: u64,
    /// Bytes of normals stored, once per block (the rest of the file is what a flat build
    /// stores).
    #[serde(default)]
    pub normal_bytes: u64,
    /// Triangles of single-sided surfaces (glTF `doubleSided` false): never drawn from behind.
    #[serde(default)]
    pub single_sided_triangles: u64,
    /// Images and the textures that sample them (an image under two samplers or cutoffs is
    /// one image, two textures).
    #[serde(default)]
    pub images: u64,
    #[serde(default)]
    pub textures: u64,
    /// Bytes of the images' mip chains, RGBA8, and of the blocks' texture coordinates (once
    /// per block): what only the display reads.
    #[serde(default)]
    pub texel_bytes: u64,
    #[serde(default)]
    pub texcoord_bytes: u64,
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
pub struct Times(pub(super) BTreeMap<String, f64>);

impl Times {
    pub fn run<T>(&mut self, stage: &str, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let r = f();
        *self.0.entry(stage.to_owned()).or_default() += t.elapsed().as_secs_f64();
        r
    }
}

/// Interior nodes left without an HLOD, by reason.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct GroupsNotBuilt {
    /// Simplification kept too much of the children.
    pub not_coarser: u64,
    /// The children's coarsest levels are too small to merge.
    pub vanished: u64,
    /// An object under the node reaches outside it.
    pub open: u64,
}

/// The report's lines for the LODs and HLODs the build did not make, and why.
pub(crate) fn report_left_out(report: &mut BuildReport, lod: &LodStats, groups_not_built: GroupsNotBuilt) {
    let GroupsNotBuilt { not_coarser, vanished, open } = groups_not_built;
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
