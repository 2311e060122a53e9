//! `osw info`: the adapter osw renders with; with `--scene`, open and validate a scene file and
//! print its header, the time to open it and this process's resident memory (to show that
//! opening reads the tables, not the geometry).

use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Scene file.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Adapter: the first whose name contains this text [default: a GPU, else lavapipe].
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,
    /// Also read and check every geometry block and image (reads the whole file).
    #[arg(long)]
    check_geometry: bool,
    /// Also measure each LOD and HLOD's distance from the full detail it stands for against
    /// its stored error (osw_scene::error_check); fails where a level lies farther than twice
    /// its error.
    #[arg(long)]
    check_errors: bool,
}

/// A coarser level may lie this many times its stored error from its full detail before
/// `--check-errors` fails: the build measures each step from fewer points than the check.
const ERROR_SLACK: f32 = 2.0;

pub fn run(a: Args) -> anyhow::Result<()> {
    // Without a scene the adapter is the question, and not having one is the answer's error.
    match osw_gpu::Gpu::new(a.adapter.as_deref()) {
        Ok(g) => {
            let i = &g.info;
            out!("adapter: {} ({:?}, {:?}, driver {} {})", i.name, i.device_type, i.backend, i.driver, i.driver_info);
            out!("device_type: {:?}", i.device_type);
            out!(
                "instances: {}",
                match osw_gpu::uses::Rows::of(&g) {
                    osw_gpu::uses::Rows::Exact => "placed on the GPU in f64, as the build places a copy (64-bit floats in shaders)",
                    osw_gpu::uses::Rows::Single => {
                        "placed on the GPU in f32, within a rounding of the build's placement (no 64-bit floats in shaders)"
                    }
                }
            );
        }
        Err(e) if a.scene.is_some() => out!("adapter: none ({e})"),
        Err(e) => return Err(e.into()),
    }
    let Some(path) = &a.scene else { return Ok(()) };
    let rss_before = osw_render::stats::resident_bytes();
    let t = Instant::now();
    let scene = osw_scene::SceneFile::open(path)?;
    let open_ms = t.elapsed().as_secs_f64() * 1e3;
    let rss_open = osw_render::stats::resident_bytes();
    let h = scene.header();
    let file_bytes = h.file_bytes;
    out!("scene: {}", path.display());
    out!("content_hash: {}", osw_scene::format::hash_hex(h.content_hash));
    out!(
        "nodes: {} ({} BVH, {} LOD/HLOD), leaves: {}, objects: {}, full-detail triangles: {}",
        h.node_count,
        h.bvh_count,
        h.node_count - h.bvh_count,
        h.leaf_count,
        h.object_count,
        h.leaf_triangles
    );
    let cuts = scene.nodes()[h.bvh_count as usize..].iter().filter(|n| n.is_cut()).count();
    if cuts > 0 {
        out!("detail: a cluster hierarchy per object (--lod clusters), {cuts} cut nodes");
    } else {
        out!("detail: static LOD chains and HLODs (--lod chains)");
    }
    out!("origin: {:?}", h.origin);
    if h.image_count > 0 {
        let largest = scene.images().iter().map(|m| m.width.max(m.height)).max().unwrap_or(0);
        out!(
            "textures: {} images ({} bytes of mip chains, the largest {largest} texels a side), {} textures",
            h.image_count,
            h.texels_bytes,
            h.texture_count
        );
    } else {
        out!("textures: none");
    }
    out!("file_bytes: {file_bytes}");
    out!("open_ms: {open_ms:.2}");
    out!(
        "resident_bytes_after_open: {} (grew by {}, {:.1}% of the file)",
        rss_open,
        rss_open.saturating_sub(rss_before),
        100.0 * rss_open.saturating_sub(rss_before) as f64 / file_bytes as f64
    );
    if a.check_geometry {
        let t = Instant::now();
        for id in scene.bvh_count()..h.node_count {
            scene.geometry(id)?;
        }
        for k in 0..h.image_count {
            scene.texels(k)?;
        }
        out!(
            "geometry: all {} blocks and {} images pass their hash and index checks in {:.1} ms",
            h.block_count,
            h.image_count,
            t.elapsed().as_secs_f64() * 1e3
        );
        let rss_read = osw_render::stats::resident_bytes();
        out!(
            "resident_bytes_after_geometry: {} (grew by {} since opening, {:.1}% of the file)",
            rss_read,
            rss_read.saturating_sub(rss_open),
            100.0 * rss_read.saturating_sub(rss_open) as f64 / file_bytes as f64
        );
    }
    if a.check_errors {
        let t = Instant::now();
        let levels = osw_scene::error_check::measure(&scene)?;
        let over: Vec<_> = levels.iter().filter(|m| m.ratio() > ERROR_SLACK).collect();
        let worst = levels.iter().max_by(|a, b| a.ratio().total_cmp(&b.ratio()));
        out!(
            "lod_errors: {} coarser levels measured from their full detail in {:.1} s; {} lie farther than {ERROR_SLACK}x their stored error{}",
            levels.len(),
            t.elapsed().as_secs_f64(),
            over.len(),
            worst.map_or(String::new(), |m| format!(
                "; the farthest for its error: LOD node {} of node {}, {:.4} from its full detail at a stored error of {:.4} ({:.2}x)",
                m.lod,
                m.node,
                m.distance,
                m.error,
                m.ratio()
            ))
        );
        if !over.is_empty() {
            anyhow::bail!(
                "{}: {} of {} coarser levels understate their error (more than {ERROR_SLACK}x)",
                path.display(),
                over.len(),
                levels.len()
            );
        }
    }
    Ok(())
}
