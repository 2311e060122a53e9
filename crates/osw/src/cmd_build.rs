//! `osw build`: input (glTF, GLB, OBJ, PLY or a generator) → scene file + `<scene>.build.json`.

use anyhow::{Context, bail};
use osw_scene::build::{Instances, Lod};
use osw_scene::generators::GenKind;
use osw_scene::smooth::Normals;
use osw_scene::source::{InMemory, Shifted, Source};
use osw_scene::{BuildOptions, build};
use std::path::PathBuf;

#[derive(clap::Args)]
#[command(group = clap::ArgGroup::new("source").required(true).args(["input", "generator"]))]
pub struct Args {
    /// Input model: .gltf (external or embedded buffers) or .glb (also quantized, meshopt-compressed
    /// and instanced, as gltfpack writes them), .obj (with its .mtl files) or .ply (ASCII or
    /// binary, float or double).
    input: Option<PathBuf>,
    /// Generate a scene instead: city, teapots, plant (streamed: any size, a site of buildings
    /// above 100M), forest (Bartz 1999's trees before a castle) or isosurface (Yoon 2003's
    /// second environment: one closed object, a sponge of noise, layer behind layer).
    #[arg(long = "gen", value_name = "KIND")]
    generator: Option<GenKind>,
    /// Triangle budget of a generated scene.
    #[arg(long, default_value_t = 1_000_000, value_name = "N")]
    triangles: u64,
    /// Seed of a generated scene (same seed, same scene, same content hash).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// With --gen plant: the plant made of catalogue parts (bay designs, each object a use of
    /// its design's mesh, 2.5% of the triangles unique), up to 20B triangles as drawn.
    #[arg(long)]
    instanced: bool,
    /// Largest chunk in triangles (objects above it are split).
    #[arg(long, default_value_t = osw_scene::limits::CHUNK_TRIANGLES, value_name = "N")]
    chunk_triangles: u32,
    /// Split a chunk in two where its halves' boxes have less than this fraction of its box's
    /// surface area, so that HC tests boxes that fit (elbowed pipes, railings); 0 never splits.
    #[arg(long, default_value_t = osw_scene::limits::LOOSE_SPLIT, value_name = "FRACTION")]
    loose_split: f32,
    /// Moves the scene by "X,Y,Z" in the world (e.g. a generated one, to test precision far from
    /// the origin), in f64 like a model's own coordinates.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_offset)]
    offset: Option<[f64; 3]>,
    /// Colours: the model's own (glTF baseColorFactor and COLOR_0, OBJ Kd, PLY red green blue;
    /// objects without one in hashed colours), or hashed for every object.
    #[arg(long, value_enum, default_value_t = Colors::Model)]
    colors: Colors,
    /// Normals for shading: `smooth` keeps the model's (glTF NORMAL, OBJ vn, PLY nx ny nz) and
    /// computes the rest, weighted by area and angle; `flat` stores none (every facet shaded
    /// from its depth, and 4 bytes a vertex less).
    #[arg(long, value_enum, default_value_t = Shading::Smooth)]
    normals: Shading,
    /// Where computed normals split: faces meeting at a sharper angle (degrees, 0 to 180) keep
    /// their own normals along their edge. The default keeps a box's and an octagon's edges
    /// and rounds a pipe of twelve facets or more.
    #[arg(long, default_value_t = osw_scene::smooth::CREASE_DEGREES, value_name = "DEGREES")]
    crease_angle: f32,
    /// Sides: `model` culls the back faces of single-sided surfaces (glTF materials without
    /// doubleSided) in every pass; `both` draws every surface from both sides, for a model
    /// whose triangles are not wound counter-clockwise as glTF says (OBJ and PLY are drawn
    /// from both sides either way).
    #[arg(long, value_enum, default_value_t = Sides::Model)]
    sides: Sides,
    /// Most input triangles built in memory at once (one subtree of the hierarchy at a time:
    /// peak memory follows this, not the model's size). The scene is the same for any value;
    /// only the order of its blocks in the file changes.
    #[arg(long, default_value_t = osw_scene::limits::BUCKET_TRIANGLES, value_name = "N")]
    bucket_triangles: u64,
    /// How detail is reduced: `chains` (static LOD levels per chunk, chosen whole, borders
    /// locked) or `clusters` (a cluster hierarchy per object whose detail varies across a
    /// surface, Yoon 2003's view-dependent rendering as meshoptimizer's clusterlod builds it).
    #[arg(long, default_value_t = Lod::Chains, value_name = "chains|clusters")]
    lod: Lod,
    /// A mesh the input uses several times (glTF nodes sharing a mesh, EXT_mesh_gpu_instancing):
    /// `keep` stores it once with a transform per use; `expand` stores a placed copy per use
    /// (the same triangles: for comparisons). Either way it is cleaned and simplified once, in
    /// its own frame. With `--lod clusters` every use is expanded.
    #[arg(long, default_value = "keep", value_name = "keep|expand")]
    instances: Instances,
    /// Output scene file; the report goes beside it as <scene>.build.json. A temporary
    /// <scene>.osw.spill of about the input's size lies beside it while building.
    #[arg(short, long)]
    output: PathBuf,
}

/// Most triangles of a generated scene: a plant's leaves, LODs and HLODs take node ids (u32)
/// and table memory by the chunk; an instanced plant's triangles cost the file nothing.
const MOST_TRIANGLES: u64 = 4_000_000_000;
const MOST_INSTANCED: u64 = 20_000_000_000;
/// Most triangles of a generator that makes its scene in memory (all but the plant): about 6 GB
/// of mesh and build tables at 100M.
const MOST_IN_MEMORY: u64 = 100_000_000;

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Sides {
    Model,
    Both,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Shading {
    Smooth,
    Flat,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Colors {
    Model,
    Hashed,
}

fn parse_offset(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s.split(',').map(|t| t.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|e| format!("{s:?}: {e}"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("{s:?}: expected three finite numbers X,Y,Z")),
    }
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if a.chunk_triangles == 0 {
        bail!("--chunk-triangles must be at least 1");
    }
    if !(0.0..=1.0).contains(&a.loose_split) {
        bail!("--loose-split must be a fraction from 0 to 1 (got {})", a.loose_split);
    }
    if a.bucket_triangles == 0 {
        bail!("--bucket-triangles must be at least 1");
    }
    if !(0.0..=180.0).contains(&a.crease_angle) {
        bail!("--crease-angle must be from 0 to 180 degrees (got {})", a.crease_angle);
    }
    let started = std::time::Instant::now();
    let bar = crate::progress::Bar::new();
    let Input { source, name: input, notes, left_out } = input(&a)?;
    let mut source = match a.offset {
        Some(by) => Box::new(Shifted { inner: source, by: glam::DVec3::from_array(by) }),
        None => source,
    };
    let opts = BuildOptions {
        chunk_triangles: a.chunk_triangles,
        loose_split: a.loose_split,
        model_colors: a.colors == Colors::Model,
        normals: match a.normals {
            Shading::Smooth => Normals::Smooth { crease_degrees: a.crease_angle },
            Shading::Flat => Normals::Flat,
        },
        model_sides: a.sides == Sides::Model,
        bucket_triangles: a.bucket_triangles,
        lod: a.lod,
        instances: a.instances,
        find_repeats: a.input.is_some(),
    };
    let report = build(source.as_mut(), &input, notes, &opts, &a.output, started, &bar);
    bar.finish();
    let mut report = report?;
    report.left_out.splice(0..0, left_out);
    report.peak_rss_kb = osw_render::stats::peak_resident_kb();
    let json = a.output.with_extension("build.json");
    std::fs::write(&json, serde_json::to_string_pretty(&report)?).with_context(|| format!("writing {}", json.display()))?;
    print_report(&report, a.loose_split);
    out!("wrote {} and {}", a.output.display(), json.display());
    Ok(())
}

/// What a build reads: its source, the name the report gives it, the notes that come with it
/// and what of the input it leaves out.
struct Input {
    source: Box<dyn Source>,
    name: String,
    notes: Vec<String>,
    left_out: Vec<String>,
}

/// The model file, or the generator with its size checked against what it can make.
fn input(a: &Args) -> anyhow::Result<Input> {
    Ok(match (&a.input, a.generator) {
        (Some(path), _) => {
            let imported = osw_scene::import::read(path)?;
            let notes = imported.skipped.iter().map(|s| format!("skipped {s}")).collect::<Vec<_>>();
            for s in &imported.skipped {
                tracing::warn!("{}: skipped {s}", path.display());
            }
            let name = path.display().to_string();
            Input { source: Box::new(InMemory::textured(imported.objects, imported.textures)), name, notes, left_out: imported.left_out }
        }
        (None, Some(kind)) => {
            if a.instanced && kind != GenKind::Plant {
                bail!("--instanced is a plant of catalogue parts: it needs --gen plant");
            }
            let most = if a.instanced { MOST_INSTANCED } else { MOST_TRIANGLES };
            if a.triangles > most {
                bail!(
                    "--triangles {} is above the {}M this generator makes (node ids are u32; --instanced takes up to {}M)",
                    a.triangles,
                    most / 1_000_000,
                    MOST_INSTANCED / 1_000_000
                );
            }
            if kind != GenKind::Plant && a.triangles > MOST_IN_MEMORY {
                bail!(
                    "--triangles {}: --gen {} makes its scene in memory, at most {}M triangles (the plant streams at any size)",
                    a.triangles,
                    format!("{kind:?}").to_lowercase(),
                    MOST_IN_MEMORY / 1_000_000
                );
            }
            let instanced = if a.instanced { " --instanced" } else { "" };
            let input = format!("--gen {kind:?}{instanced} --triangles {} --seed {}", a.triangles, a.seed).to_lowercase();
            let (source, notes): (Box<dyn Source>, _) = match kind {
                // The plant streams (a site of any size); the others are small by nature.
                GenKind::Plant if a.instanced => {
                    (Box::new(osw_scene::generators::plant::Site::instanced(a.triangles.max(1_000), a.seed)), Vec::new())
                }
                GenKind::Plant => (Box::new(osw_scene::generators::plant::Site::new(a.triangles.max(1_000), a.seed)), Vec::new()),
                _ => {
                    let g = osw_scene::generators::generate(kind, a.triangles, a.seed);
                    (Box::new(InMemory::new(g.objects)), g.notes)
                }
            };
            Input { source, name: input, notes, left_out: Vec::new() }
        }
        (None, None) => unreachable!("clap requires a source"),
    })
}

/// The build's report in a few lines: what it made, and what it left out.
fn print_report(report: &osw_scene::BuildReport, loose_split: f32) {
    out!(
        "build: {} input triangles → {} nodes ({} leaves, {} HLODs, up to {} LOD levels), {:.1} MB in {:.2} s ({:.2} M triangles/s, peak memory {:.2} GB, temporary disk {:.2} GB, {} subtrees of up to {} triangles)",
        report.input_triangles,
        report.nodes,
        report.leaves,
        report.hlod_nodes,
        report.lod_levels_max,
        report.output_bytes as f64 / 1e6,
        report.seconds,
        report.input_triangles_per_second / 1e6,
        report.peak_rss_kb as f64 / 1e6 * 1.024,
        report.temp_bytes as f64 / 1e9,
        report.buckets,
        report.bucket_triangles
    );
    if report.lod == "clusters" {
        out!(
            "cluster hierarchy: {} simplified groups in {} pieces, up to {} levels, {} cut nodes",
            report.simplified_groups,
            report.simplified_pieces,
            report.cluster_levels_max,
            report.cut_nodes
        );
    }
    if report.instances > 0 {
        out!(
            "repeats: {} uses of meshes used more than once ({} found by content, unnamed in the input), {} triangles of {} unique; {} meshes stored once, {:.1} MB of blocks shared",
            report.instances,
            report.found_repeats,
            report.instanced_triangles,
            report.unique_triangles,
            report.prototypes,
            report.bytes_saved as f64 / 1e6
        );
    }
    out!("colours: {} of {} objects have none of their own (drawn in hashed colours)", report.objects_without_color, report.objects);
    if report.translucent_triangles > 0 {
        out!(
            "translucent: {} triangles of {} objects (drawn blended after the opaque, never occluders)",
            report.translucent_triangles,
            report.translucent_objects
        );
    }
    if report.cut_out_triangles > 0 {
        out!(
            "cut-outs: {} triangles of {} objects (drawn opaque, never occluders: their holes are not read)",
            report.cut_out_triangles,
            report.cut_out_objects
        );
    }
    if report.loose_splits > 0 {
        out!("{} loose splits (--loose-split {}): {} chunks", report.loose_splits, loose_split, report.chunks);
    }
    for l in &report.left_out {
        out!("left out: {l}");
    }
}
