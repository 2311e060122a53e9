//! Stage 1 of the build: the source's batches → placement around one origin → clean-up → chunks
//! (and, for cluster hierarchies, the simplified groups: [`crate::clod`]), appended to the
//! spill file. Of each only its box and where it lies stay in memory.

use crate::aabb::Aabb;
use crate::build::{BuildError, BuildOptions, BuildReport, Lod, Progress, Times};
use crate::chunk::SplitOptions;
use crate::clod::Piece;
use crate::mesh::{CleanStats, Object};
use crate::source::Source;
use crate::spill::{Sealed, Spill, SpillRef};
use rayon::prelude::*;
use std::path::Path;

/// A chunk, the unit of the BVH (one per leaf), or a simplified group of a cluster hierarchy:
/// its object and where its piece waits.
#[derive(Clone, Copy, Debug)]
pub struct Chunk {
    pub bounds: Aabb,
    pub object: u32,
    pub triangles: u32,
    pub spill: SpillRef,
}

/// What the stream left for the rest of the build.
pub struct Streamed {
    pub chunks: Vec<Chunk>,
    /// The simplified groups of the objects' cluster hierarchies (none for LOD chains).
    pub coarse: Vec<Chunk>,
    pub spill: Sealed,
    /// Per object: its box when it is closed and wound outwards (see [`crate::cluster`]).
    pub closed_objects: Vec<Option<Aabb>>,
    pub origin: glam::DVec3,
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
    let mut spill = Spill::create(out).map_err(|e| BuildError::temp(out, e))?;
    let split = SplitOptions { max_triangles: opts.chunk_triangles, loose: opts.loose_split };
    let (mut chunks, mut coarse, mut closed_objects) = (Vec::new(), Vec::new(), Vec::new());
    let (mut seen, mut clean_stats, mut empty, mut colors_dropped) = (0, CleanStats::default(), Vec::new(), 0);
    let mut repeats = Repeats::default();
    progress.stage("input", source.triangles_hint());
    loop {
        if progress.cancelled() {
            return Err(BuildError::Interrupted);
        }
        let Some(mut batch) = times.run("input", || source.next_batch()) else { break };
        let triangles: u64 = batch.iter().map(|o| o.mesh.triangle_count() as u64).sum();
        report.input_triangles += triangles;
        times.run("place", || crate::place::to_local(&mut batch, origin));
        if !opts.model_colors {
            colors_dropped += batch.iter().filter(|o| !o.mesh.colors.is_empty()).count();
            batch.iter_mut().for_each(|o| o.mesh.colors = Vec::new());
        }
        let cleaned = times.run("clean", || clean(batch, seen))?;
        seen += cleaned.len();
        cleaned.iter().for_each(|(o, _)| repeats.add(o));
        // Whether each object is closed and wound outwards is decided on the whole object,
        // before chunks cut it open (see crate::cluster).
        let split: Vec<_> = times.run("chunk", || {
            cleaned
                .into_par_iter()
                .map(|(o, stats)| {
                    let closed = crate::cluster::Parts::of(&o.mesh).all_closed().then(|| o.mesh.bounds());
                    let chunks = (!o.mesh.is_empty()).then(|| match opts.lod {
                        Lod::Chains => {
                            let c = crate::chunk::split(&o.mesh, split);
                            (c.meshes.into_iter().map(Piece::always).collect(), Vec::new(), c.loose_splits, 0)
                        }
                        Lod::Clusters => {
                            let h = crate::clod::build(&o.mesh, split.max_triangles);
                            (h.chunks, h.coarse, 0, h.levels)
                        }
                    });
                    (o.name, o.mesh.colors.is_empty(), o.mesh.translucent_triangles() as u64, stats, closed, chunks)
                })
                .collect()
        });
        times.run("spill", || -> Result<(), BuildError> {
            for (name, uncolored, translucent, stats, closed, split) in split {
                clean_stats.add(stats);
                let Some((pieces, simplified, loose_splits, levels)) = split else {
                    empty.push(name);
                    continue;
                };
                let object = closed_objects.len() as u32;
                closed_objects.push(closed);
                report.objects_without_color += u64::from(uncolored);
                report.translucent_triangles += translucent;
                report.translucent_objects += u64::from(translucent > 0);
                report.loose_splits += loose_splits as u64;
                report.cluster_levels_max = report.cluster_levels_max.max(levels as u64);
                for (to, pieces) in [(&mut chunks, &pieces), (&mut coarse, &simplified)] {
                    for p in pieces {
                        let at = spill.append(p).map_err(|e| BuildError::temp(spill.path(), e))?;
                        to.push(Chunk { bounds: p.mesh.bounds(), object, triangles: p.mesh.triangle_count() as u32, spill: at });
                    }
                }
            }
            Ok(())
        })?;
        progress.advance(triangles);
    }
    report.objects = closed_objects.len() as u64;
    report.chunks = chunks.len() as u64;
    report.closed_objects = closed_objects.iter().filter(|c| c.is_some()).count() as u64;
    report.degenerate_triangles_dropped = clean_stats.degenerate_triangles;
    if colors_dropped > 0 {
        report.left_out.push(format!("the model's colours and translucency of {colors_dropped} objects (--colors hashed)"));
    }
    if clean_stats.degenerate_triangles > 0 {
        report
            .left_out
            .push(format!("{} degenerate triangles (repeated index or zero area): they cover no pixel", clean_stats.degenerate_triangles));
    }
    if !empty.is_empty() {
        let names: Vec<&str> = empty.iter().take(5).map(String::as_str).collect();
        report.left_out.push(format!("{} objects with no triangles left after clean-up, e.g. {}", empty.len(), names.join(", ")));
    }
    repeats.report(report);
    if chunks.is_empty() {
        return Err(BuildError::Empty(format!("no triangles in the input ({} objects)", empty.len())));
    }
    report.temp_bytes = spill.bytes();
    let spill = spill.seal().map_err(|e| BuildError::temp(out, e))?;
    Ok(Streamed { chunks, coarse, spill, closed_objects, origin })
}

/// Per prototype: its first use's triangles after clean-up, its uses and their triangles
/// (clean-up runs after placement, in the scene's f32 coordinates, so a use turned otherwise
/// may keep a few near-degenerate triangles more or fewer); the triangles of objects of no
/// prototype.
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
    fn add(&mut self, o: &Object) {
        let triangles = o.mesh.triangle_count() as u64;
        match o.prototype {
            Some(p) => {
                let u = self.prototypes.entry(p).or_insert(Uses { first: triangles, uses: 0, triangles: 0 });
                (u.uses, u.triangles) = (u.uses + 1, u.triangles + triangles);
            }
            None => self.single += triangles,
        }
    }

    fn report(&self, report: &mut BuildReport) {
        let repeated = || self.prototypes.values().filter(|u| u.uses > 1);
        report.unique_triangles = self.single + self.prototypes.values().map(|u| u.first).sum::<u64>();
        report.instanced_triangles = repeated().map(|u| u.triangles).sum();
        report.instances = repeated().map(|u| u.uses).sum();
        if report.instances > 0 {
            let once: u64 = repeated().map(|u| u.first).sum();
            report.left_out.push(format!(
                "storing repeats once: {} objects are uses of {} meshes that the input uses more than once, {} triangles where {} would do; each use is built and stored in full",
                report.instances,
                repeated().count(),
                report.instanced_triangles,
                once
            ));
        }
    }
}

/// Cleans a batch whose first object is the input's `first`-th (errors name it by that index).
fn clean(batch: Vec<Object>, first: usize) -> Result<Vec<(Object, CleanStats)>, BuildError> {
    batch
        .into_par_iter()
        .enumerate()
        .map(|(i, o)| {
            let (mesh, stats) = o.mesh.clean().map_err(|source| BuildError::Mesh { index: first + i, name: o.name.clone(), source })?;
            Ok((Object { mesh, ..o }, stats))
        })
        .collect()
}
