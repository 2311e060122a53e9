//! Stage 1 of the build: the source's batches → placement around one origin → clean-up → chunks
//! (and, for cluster hierarchies, the simplified groups: [`crate::clod`]), appended to the
//! spill file. Of each only its box and where it lies stay in memory.
//!
//! A mesh that the input uses several times (with LOD chains) goes another way: at its first
//! use it is cleaned and cut into chunks in its own frame, once; each use then adds an
//! [`InstanceRecord`] and a chunk per part with the part's placed box (see [`crate::instance`]).

use super::error::BuildError;
use super::options::{BuildOptions, Instances, Lod};
use super::report::{BuildReport, Times};
use crate::aabb::Aabb;
use crate::chunk::SplitOptions;
use crate::clod::Piece;
use crate::format::{InstanceRecord, NONE};
use crate::instance::Placement;
use crate::mesh::{CleanStats, Mesh, MeshError, Object};
use crate::progress::Progress;
use crate::smooth::Normals;
use crate::source::Source;
use crate::spill::{Sealed, Spill, SpillRef};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::path::Path;

/// A chunk, the unit of the BVH (one per leaf), or a simplified group of a cluster hierarchy:
/// its object and where its piece waits.
#[derive(Clone, Copy, Debug)]
pub struct Chunk {
    pub bounds: Aabb,
    pub object: u32,
    pub triangles: u32,
    pub spill: SpillRef,
    /// The use of a stored-once mesh it is part of, and which of [`Prototypes::parts`] it
    /// places (both NONE for a chunk of its own).
    pub instance: u32,
    pub part: u32,
}

impl Chunk {
    pub fn own(bounds: Aabb, object: u32, triangles: u32, spill: SpillRef) -> Chunk {
        Chunk { bounds, object, triangles, spill, instance: NONE, part: NONE }
    }
}

/// The meshes stored once, cleaned and cut in their own frames.
#[derive(Default)]
pub struct Prototypes {
    pub parts: Vec<Part>,
    /// Per prototype: its box when it is closed and wound outwards, and the largest scale of
    /// its uses (its LODs' errors are bounded in the scene's units through it).
    pub closed: Vec<Option<Aabb>>,
    pub scale: Vec<f32>,
}

/// A chunk of a prototype, in its frame.
#[derive(Clone, Copy, Debug)]
pub struct Part {
    pub prototype: u32,
    pub triangles: u32,
    pub spill: SpillRef,
}

/// What the stream left for the rest of the build: the chunks, and the spill file holding
/// their triangles.
pub struct Streamed {
    pub chunked: Chunked,
    pub spill: Sealed,
}

/// The model cut into chunks, each naming its triangles in the spill.
pub struct Chunked {
    pub chunks: Vec<Chunk>,
    /// The pieces of the simplified clusters of the objects' cluster hierarchies (none for LOD
    /// chains), and the chunk each lies in.
    pub coarse: Vec<Chunk>,
    pub coarse_chunk: Vec<u32>,
    /// Per object: its box when it is closed and wound outwards (see [`crate::cluster`]).
    pub closed_objects: Vec<Option<Aabb>>,
    pub origin: glam::DVec3,
    pub prototypes: Prototypes,
    pub instances: Vec<InstanceRecord>,
}

pub fn stream(
    source: &mut dyn Source,
    opts: &BuildOptions,
    out: &Path,
    report: &mut BuildReport,
    times: &mut Times,
    progress: &dyn Progress,
) -> Result<Streamed, BuildError> {
    let origin = source.world_bounds().origin();
    let spill = Spill::create(out).map_err(|e| BuildError::temp(out, e))?;
    // Meshes are stored once only with LOD chains: a cluster hierarchy's groups coarser than a
    // chunk belong to BVH nodes (the build's owner stage), which differ from use to use.
    let instancing = opts.lod == Lod::Chains;
    let mut s = Stream {
        opts,
        origin,
        split: SplitOptions { max_triangles: opts.chunk_triangles, loose: opts.loose_split },
        instancing,
        spill,
        report,
        chunks: Vec::new(),
        coarse: Vec::new(),
        coarse_chunk: Vec::new(),
        closed_objects: Vec::new(),
        prototypes: Prototypes::default(),
        seen: FxHashMap::default(),
        contents: FxHashMap::default(),
        find_repeats: instancing && opts.find_repeats,
        unnamed: Default::default(),
        instances: Vec::new(),
        repeats: Repeats::default(),
        clean_stats: CleanStats::default(),
        empty: Vec::new(),
        objects_seen: 0,
        colors_dropped: 0,
        sides_dropped: 0,
    };
    progress.stage("input", source.triangles_hint());
    loop {
        if progress.cancelled() {
            return Err(BuildError::Interrupted);
        }
        let Some(batch) = times.run("input", || source.next_batch()) else { break };
        let before = s.report.input_triangles;
        s.batch(batch, times)?;
        progress.advance(s.report.input_triangles - before);
    }
    s.finish(out)
}

/// An object cleaned and cut.
struct CutObject {
    name: String,
    /// The input mesh it uses, if it names one.
    prototype: Option<u32>,
    kept: Kept,
    stats: CleanStats,
    /// Its box when it is closed and wound outwards.
    closed: Option<Aabb>,
    /// Its cluster hierarchy (chunks alone for LOD chains) and the loose splits it took; none
    /// when nothing of it was left.
    hierarchy: Option<(crate::clod::Hierarchy, u32)>,
}

impl Stream<'_> {
    /// One batch of the input: uses of stored-once meshes, objects of their own cleaned, cut
    /// into chunks and appended to the spill.
    fn batch(&mut self, mut batch: Vec<Object>, times: &mut Times) -> Result<(), BuildError> {
        self.report.input_triangles += batch.iter().map(|o| o.mesh.triangle_count() as u64).sum::<u64>();
        if !self.opts.model_colors {
            self.colors_dropped += batch.iter().filter(|o| !o.mesh.colors.is_empty()).count();
            batch.iter_mut().for_each(|o| o.mesh.colors = Vec::new());
        }
        self.report.objects_with_model_normals += batch.iter().filter(|o| !o.mesh.normals.is_empty()).count() as u64;
        if !self.opts.model_sides {
            self.sides_dropped += batch.iter().filter(|o| !o.mesh.single_sided.is_empty()).count();
            batch.iter_mut().for_each(|o| o.mesh.single_sided = Vec::new());
        }
        let first = self.objects_seen;
        self.objects_seen += batch.len();
        let instancing = self.instancing;
        let (uses, own): (Vec<_>, Vec<_>) =
            batch.into_iter().enumerate().map(|(i, o)| (first + i, o)).partition(|(_, o)| instancing && o.prototype.is_some());
        let (origin, split) = (self.origin, self.split);
        for (index, o) in uses {
            times.run("clean", || self.add_use(index, o, origin, split))?;
        }
        let own = times.run("repeats", || self.found_repeats(own, origin, split))?;
        let (indices, mut own): (Vec<usize>, Vec<Object>) = own.into_iter().unzip();
        times.run("place", || crate::place::to_local(&mut own, origin));
        let normals = self.opts.normals;
        let cleaned = times.run("clean", || clean(indices.into_iter().zip(own).collect(), normals))?;
        let lod = self.opts.lod;
        let cut: Vec<CutObject> = times.run("chunk", || cleaned.into_par_iter().map(|(o, stats)| cut(o, stats, lod, split)).collect());
        times.run("spill", || cut.into_iter().try_for_each(|c| self.spill_object(c)))
    }

    /// Appends an object's chunks and simplified pieces to the spill.
    fn spill_object(&mut self, o: CutObject) -> Result<(), BuildError> {
        let CutObject { name, prototype, kept, stats, closed, hierarchy } = o;
        self.clean_stats.add(stats);
        let Some((h, loose_splits)) = hierarchy else {
            self.empty.push(name);
            return Ok(());
        };
        self.repeats.add(prototype, kept.triangles);
        let object = self.object(closed, &kept);
        self.report.loose_splits += loose_splits as u64;
        self.report.cluster_levels_max = self.report.cluster_levels_max.max(h.levels as u64);
        self.report.simplified_groups += h.groups;
        self.report.simplified_pieces += h.coarse.len() as u64;
        self.report.fin_triangles_dropped += h.fins;
        let first = self.chunks.len() as u32;
        self.coarse_chunk.extend(h.home.iter().map(|&k| first + k));
        for (coarse, pieces) in [(false, &h.chunks), (true, &h.coarse)] {
            for p in pieces {
                let at = self.spill.append(p).map_err(|e| BuildError::temp(self.spill.path(), e))?;
                let c = Chunk::own(p.mesh.bounds(), object, p.mesh.triangle_count() as u32, at);
                if coarse { self.coarse.push(c) } else { self.chunks.push(c) }
            }
        }
        Ok(())
    }

    /// The report's counts and what the stream left out; the spill sealed for reading.
    fn finish(self, out: &Path) -> Result<Streamed, BuildError> {
        let Stream {
            opts,
            origin,
            instancing,
            spill,
            report,
            chunks,
            coarse,
            coarse_chunk,
            closed_objects,
            prototypes,
            instances,
            repeats,
            clean_stats,
            empty,
            colors_dropped,
            sides_dropped,
            ..
        } = self;
        report.objects = closed_objects.len() as u64;
        report.chunks = chunks.len() as u64;
        report.closed_objects = closed_objects.iter().filter(|c| c.is_some()).count() as u64;
        report.degenerate_triangles_dropped = clean_stats.degenerate_triangles;
        if opts.normals == Normals::Flat && report.objects_with_model_normals > 0 {
            let n = report.objects_with_model_normals;
            report.left_out.push(format!("the model's normals of {n} objects (--normals flat: every surface shaded flat)"));
        }
        if sides_dropped > 0 {
            report.left_out.push(format!(
                "the back-face culling of {sides_dropped} objects' single-sided surfaces (--sides both: drawn from both sides)"
            ));
        }
        if colors_dropped > 0 {
            report.left_out.push(format!(
                "the model's colours, translucency and cut-outs of {colors_dropped} objects (--colors hashed: glass and cut-outs drawn opaque, and occluding)"
            ));
        }
        if clean_stats.degenerate_triangles > 0 {
            report.left_out.push(format!(
                "{} degenerate triangles (repeated index or zero area): they cover no pixel",
                clean_stats.degenerate_triangles
            ));
        }
        if report.fin_triangles_dropped > 0 {
            report.left_out.push(format!(
                "{} triangles of simplified groups in fins: pairs on the same corners wound opposite ways, folded by simplification within the group's error of the surface kept",
                report.fin_triangles_dropped
            ));
        }
        if !empty.is_empty() {
            let names: Vec<&str> = empty.iter().take(5).map(String::as_str).collect();
            report.left_out.push(format!("{} objects with no triangles left after clean-up, e.g. {}", empty.len(), names.join(", ")));
        }
        let why = match (instancing, opts.instances) {
            (false, _) => Some("cluster hierarchies (--lod clusters) are built per object"),
            (true, Instances::Expand) => Some("--instances expand"),
            (true, Instances::Keep) => None,
        };
        repeats.report(report, why, opts.find_repeats);
        report.prototypes = if why.is_none() { prototypes.closed.len() as u64 } else { 0 };
        if chunks.is_empty() {
            return Err(BuildError::Empty(format!("no triangles in the input ({} objects)", empty.len())));
        }
        report.temp_bytes = spill.bytes();
        let spill = spill.seal().map_err(|e| BuildError::temp(out, e))?;
        Ok(Streamed { chunked: Chunked { chunks, coarse, coarse_chunk, closed_objects, origin, prototypes, instances }, spill })
    }
}

/// An object cut into chunks (LOD chains) or its cluster hierarchy. Whether it is closed and
/// wound outwards is decided on the whole object, before chunks cut it open (see
/// [`crate::cluster`]).
fn cut(o: Object, stats: CleanStats, lod: Lod, split: SplitOptions) -> CutObject {
    let closed = crate::cluster::Parts::of(&o.mesh).all_closed().then(|| o.mesh.bounds());
    let hierarchy = (!o.mesh.is_empty()).then(|| match lod {
        Lod::Chains => {
            let c = crate::chunk::split(&o.mesh, split);
            let chunks = c.meshes.into_iter().map(Piece::always).collect();
            (crate::clod::Hierarchy { chunks, ..Default::default() }, c.loose_splits)
        }
        Lod::Clusters => (crate::clod::build(&o.mesh, split.max_triangles), 0),
    });
    CutObject { kept: Kept::of(&o.mesh), name: o.name, prototype: o.prototype, stats, closed, hierarchy }
}

/// What the stream gathers, object by object.
struct Stream<'a> {
    opts: &'a BuildOptions,
    origin: glam::DVec3,
    split: SplitOptions,
    /// Whether uses of one mesh are kept as its instances (LOD chains only).
    instancing: bool,
    spill: Spill,
    report: &'a mut BuildReport,
    chunks: Vec<Chunk>,
    coarse: Vec<Chunk>,
    coarse_chunk: Vec<u32>,
    closed_objects: Vec<Option<Aabb>>,
    prototypes: Prototypes,
    /// The meshes seen so far that objects use, by their content (positions, indices and
    /// colours in their own frame): two glTF meshes of the same content are one prototype.
    seen: FxHashMap<u128, Seen>,
    /// The content of each input mesh seen, by the input's index, for the uses that come
    /// without their mesh.
    contents: FxHashMap<u32, u128>,
    /// Whether to look for repeats the input does not name, and the contents in their own
    /// frames of the meshes seen once (see [`crate::repeat`]).
    find_repeats: bool,
    unnamed: rustc_hash::FxHashSet<u128>,
    instances: Vec<InstanceRecord>,
    repeats: Repeats,
    clean_stats: CleanStats,
    empty: Vec<String>,
    /// Input objects seen so far, and those whose colours were dropped (`--colors hashed`).
    objects_seen: usize,
    colors_dropped: usize,
    /// Objects whose single-sided surfaces were made double-sided (`--sides both`).
    sides_dropped: usize,
}

/// A prototype while the input streams: what each of its uses needs.
struct Seen {
    /// The input mesh's triangles (a use that comes without it stands for as many).
    input: u64,
    /// Its index among the prototypes and its first part.
    index: u32,
    first_part: u32,
    /// Its parts' boxes and positions, for each use's placed boxes.
    parts: Vec<(Aabb, Vec<[f32; 3]>)>,
    kept: Kept,
}

/// Of an object's mesh after clean-up: what the report counts.
#[derive(Clone, Copy)]
struct Kept {
    triangles: u64,
    translucent: u64,
    cut_out: u64,
    single_sided: u64,
    uncolored: bool,
}

impl Kept {
    fn of(mesh: &Mesh) -> Kept {
        Kept {
            triangles: mesh.triangle_count() as u64,
            translucent: mesh.translucent_triangles() as u64,
            cut_out: mesh.cut_out_triangles() as u64,
            single_sided: mesh.indices.chunks_exact(3).filter(|t| mesh.is_single_sided(t)).count() as u64,
            uncolored: mesh.colors.is_empty(),
        }
    }
}

impl Stream<'_> {
    /// A new object; returns its id.
    fn object(&mut self, closed: Option<Aabb>, kept: &Kept) -> u32 {
        self.report.objects_without_color += u64::from(kept.uncolored);
        self.report.translucent_triangles += kept.translucent;
        self.report.translucent_objects += u64::from(kept.translucent > 0);
        self.report.cut_out_triangles += kept.cut_out;
        self.report.cut_out_objects += u64::from(kept.cut_out > 0);
        self.report.single_sided_triangles += kept.single_sided;
        self.closed_objects.push(closed);
        self.closed_objects.len() as u32 - 1
    }

    /// A use of a mesh in its own frame (the input's `index`-th object): its instance and its
    /// placed parts, the mesh cleaned and cut at the first use of its content.
    fn add_use(&mut self, index: usize, o: Object, origin: glam::DVec3, split: SplitOptions) -> Result<(), BuildError> {
        let named = o.prototype.expect("a use names its mesh");
        let key = match self.contents.get(&named) {
            Some(&key) if o.mesh.is_empty() => {
                self.report.input_triangles += self.seen[&key].input;
                key
            }
            _ => {
                let key = mesh_hash(&o.mesh);
                self.contents.insert(named, key);
                key
            }
        };
        // A mesh new by its content in its frame may still be an earlier one moved (a glTF
        // exported without reuse, each copy's vertices in world coordinates).
        if !self.seen.contains_key(&key)
            && let Some(t) = self.repeat(&o)
        {
            return self.use_found(index, t, o, origin, split);
        }
        self.use_content(index, key, o, origin, split)
    }

    /// `o`'s mesh in its own frame where an earlier object's was the same
    /// ([`crate::repeat`]); else None, and its content is remembered.
    fn repeat(&mut self, o: &Object) -> Option<crate::repeat::Translated> {
        if !self.find_repeats {
            return None;
        }
        let t = crate::repeat::translated(o)?;
        self.seen_before(t.content).then_some(t)
    }

    /// Whether a mesh of content `content` (in its own frame) came before; remembers it.
    fn seen_before(&mut self, content: u128) -> bool {
        self.seen.contains_key(&content) || !self.unnamed.insert(content)
    }

    /// A use of the mesh found in `t`, standing where `o` stood.
    fn use_found(
        &mut self,
        index: usize,
        t: crate::repeat::Translated,
        o: Object,
        origin: glam::DVec3,
        split: SplitOptions,
    ) -> Result<(), BuildError> {
        self.report.found_repeats += 1;
        let placement = glam::DAffine3::from_translation(t.corner);
        let mesh = Mesh { positions: t.positions, ..o.mesh };
        let o = Object { mesh, placement, anchor: glam::DVec3::ZERO, prototype: None, ..o };
        self.use_content(index, t.content, o, origin, split)
    }

    /// Of objects of their own, `own`, those whose mesh an earlier one has up to a translation
    /// become uses of it ([`crate::repeat`]; the first of each content stays its own, the
    /// second brings the mesh); returns the rest.
    fn found_repeats(
        &mut self,
        own: Vec<(usize, Object)>,
        origin: glam::DVec3,
        split: SplitOptions,
    ) -> Result<Vec<(usize, Object)>, BuildError> {
        if !self.find_repeats {
            return Ok(own);
        }
        let found: Vec<_> = own.into_par_iter().map(|(index, o)| (index, crate::repeat::translated(&o), o)).collect();
        let mut rest = Vec::with_capacity(found.len());
        for (index, t, o) in found {
            match t {
                Some(t) if self.seen_before(t.content) => {
                    self.use_found(index, t, o, origin, split)?;
                }
                _ => rest.push((index, o)),
            }
        }
        Ok(rest)
    }

    /// [`Stream::add_use`] of a mesh whose content is `key`.
    fn use_content(&mut self, index: usize, key: u128, o: Object, origin: glam::DVec3, split: SplitOptions) -> Result<(), BuildError> {
        let Object { name, mesh, placement, anchor, .. } = o;
        if !self.seen.contains_key(&key) {
            let input = mesh.triangle_count() as u64;
            let (mesh, stats) = mesh.clean().map_err(|source| BuildError::Mesh { index, name: name.clone(), source })?;
            let mesh = self.opts.normals.apply(mesh);
            self.clean_stats.add(stats);
            let closed = crate::cluster::Parts::of(&mesh).all_closed().then(|| mesh.bounds());
            let c = crate::chunk::split(&mesh, split);
            self.report.loose_splits += c.loose_splits as u64;
            let prototype = self.prototypes.closed.len() as u32;
            self.prototypes.closed.push(closed);
            self.prototypes.scale.push(0.0);
            let first_part = self.prototypes.parts.len() as u32;
            let mut parts = Vec::with_capacity(c.meshes.len());
            for m in c.meshes {
                let spill = self.spill.append(&Piece::always(m.clone())).map_err(|e| BuildError::temp(self.spill.path(), e))?;
                self.prototypes.parts.push(Part { prototype, triangles: m.triangle_count() as u32, spill });
                parts.push((m.bounds(), m.positions));
            }
            self.seen.insert(key, Seen { input, index: prototype, first_part, parts, kept: Kept::of(&mesh) });
        }
        let s = &self.seen[&key];
        if s.kept.triangles == 0 {
            self.empty.push(name);
            return Ok(());
        }
        // Whole units apart (see crate::place): the same translation wherever the model stands.
        let shift = anchor - origin;
        let place = Placement::new(glam::DAffine3 { matrix3: placement.matrix3, translation: placement.translation + shift });
        let mut chunks = Vec::with_capacity(s.parts.len());
        for (k, (bounds, positions)) in s.parts.iter().enumerate() {
            // A part turned off the axes is boxed by its vertices placed.
            let placed = if place.axis_aligned { place.bounds(*bounds) } else { Aabb::from_points(&place.points(positions)) };
            if !(placed.min.is_finite() && placed.max.is_finite()) {
                let points = place.points(positions);
                let (vertex, &pos) =
                    points.iter().enumerate().find(|(_, p)| !p.iter().all(|c| c.is_finite())).unwrap_or((0, &[f32::INFINITY; 3]));
                return Err(BuildError::Mesh { index, name, source: MeshError::NonFinite { vertex, pos } });
            }
            let part = s.first_part + k as u32;
            let triangles = self.prototypes.parts[part as usize].triangles;
            let at = self.prototypes.parts[part as usize].spill;
            chunks.push(Chunk { instance: self.instances.len() as u32, part, ..Chunk::own(placed, NONE, triangles, at) });
        }
        let (prototype, kept) = (s.index, s.kept);
        let closed = self.prototypes.closed[prototype as usize].map(|b| place.bounds(b));
        let scale = &mut self.prototypes.scale[prototype as usize];
        *scale = scale.max(place.scale);
        self.repeats.add(Some(prototype), kept.triangles);
        let object = self.object(closed, &kept);
        self.chunks.extend(chunks.into_iter().map(|c| Chunk { object, ..c }));
        self.instances.push(InstanceRecord {
            linear: place.affine.matrix3.to_cols_array(),
            translation: place.affine.translation.to_array(),
            prototype,
            object,
        });
        Ok(())
    }
}

/// Names a mesh's content (positions, indices and attributes): 128 bits of xxh3, so that two
/// meshes of one name differ in fewer than one of 2^64 models of 2^32 meshes.
fn mesh_hash(m: &Mesh) -> u128 {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    h.update(bytemuck::cast_slice(&m.positions));
    h.update(bytemuck::cast_slice(&m.indices));
    h.update(m.colors.as_flattened());
    h.update(bytemuck::cast_slice(&m.normals));
    h.update(bytemuck::cast_slice(&m.texcoords));
    h.digest128()
}

/// Per prototype: its triangles after clean-up, its uses and their triangles (a mesh not
/// stored once is cleaned after placement, in the scene's f32 coordinates, so a use turned
/// otherwise may keep a few near-degenerate triangles more or fewer); the triangles of objects
/// of no prototype.
#[derive(Default)]
struct Repeats {
    prototypes: rustc_hash::FxHashMap<u32, Uses>,
    single: u64,
}

#[derive(Clone, Copy)]
struct Uses {
    first: u64,
    uses: u64,
    triangles: u64,
}

impl Repeats {
    fn add(&mut self, prototype: Option<u32>, triangles: u64) {
        match prototype {
            Some(p) => {
                let u = self.prototypes.entry(p).or_insert(Uses { first: triangles, uses: 0, triangles: 0 });
                (u.uses, u.triangles) = (u.uses + 1, u.triangles + triangles);
            }
            None => self.single += triangles,
        }
    }

    /// The report's counts; `expanded` says why each use was stored in full, if it was.
    fn report(&self, report: &mut BuildReport, expanded: Option<&str>, searched: bool) {
        let repeated = || self.prototypes.values().filter(|u| u.uses > 1);
        report.unique_triangles = self.single + self.prototypes.values().map(|u| u.first).sum::<u64>();
        report.instanced_triangles = repeated().map(|u| u.triangles).sum();
        report.instances = repeated().map(|u| u.uses).sum();
        if let Some(why) = expanded.filter(|_| report.instances > 0) {
            let once: u64 = repeated().map(|u| u.first).sum();
            report.left_out.push(format!(
                "storing repeats once ({why}): {} objects are uses of {} meshes that the input uses more than once, {} triangles where {} would do; each use is built and stored in full",
                report.instances,
                repeated().count(),
                report.instanced_triangles,
                once
            ));
        }
        if self.single > 0 && expanded.is_none() {
            report.left_out.push(match searched {
                true => format!(
                    "looking for repeats the input does not name beyond exact translations ({} objects found to repeat an earlier one's mesh, the first of each stored as its own): {} triangles of objects with a mesh of their own are stored as they are; copies scaled, turned, or rounded apart far from the origin are not looked for",
                    report.found_repeats, self.single
                ),
                false => format!(
                    "looking for repeats the input does not name, in a generated scene (it stays as earlier figures measured it): {} triangles of objects with a mesh of their own are stored as they are",
                    self.single
                ),
            });
        }
    }
}

/// Cleans objects, each with its index in the input (errors name it by that index).
fn clean(batch: Vec<(usize, Object)>, normals: Normals) -> Result<Vec<(Object, CleanStats)>, BuildError> {
    batch
        .into_par_iter()
        .map(|(index, o)| {
            let (mesh, stats) = o.mesh.clean().map_err(|source| BuildError::Mesh { index, name: o.name.clone(), source })?;
            Ok((Object { mesh: normals.apply(mesh), ..o }, stats))
        })
        .collect()
}
