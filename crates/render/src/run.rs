//! Loops over a camera path: `osw render` (one mode) and `osw exact` (item buffer).

use crate::mode::{Mode, ModeError, ModeState};
use crate::output::{OutputError, frame_path, items_path, push_ids, write_items, write_png};
use crate::pass::HcTest;
use crate::results::{self, Details, ExactFrame, RenderSummary, ResultsError, Summary};
use crate::stats::FrameStats;
use osw_gpu::exact::Reference;
use osw_gpu::renderer::{RenderError, Renderer};
use osw_scene::{Camera, SceneFile};
use std::path::Path;

/// Why a run stopped: the GPU, a file it writes, or a mode that does not run on one GPU.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Output(#[from] OutputError),
    #[error(transparent)]
    Results(#[from] ResultsError),
    #[error(transparent)]
    Mode(#[from] ModeError),
}

fn write(path: &Path, text: &str) -> Result<(), RunError> {
    Ok(std::fs::write(path, text).map_err(OutputError::io(path))?)
}

/// One run of `osw render`.
pub struct RunSpec<'a> {
    /// Scene and path files, named in the summary.
    pub scene: &'a Path,
    pub path: &'a Path,
    pub mode: Mode,
    pub tau: f64,
    pub hc: HcTest,
    /// ovc's knobs (Bartz 1999; the other modes ignore them).
    pub ovc: osw_cull::ovc::OvcOptions,
    /// Occlusion culling on every frame, also where it does not pay (prev and chc as the
    /// papers run them); else cost-adaptive (osw_cull::payoff).
    pub always_cull: bool,
    /// Output directory.
    pub out: &'a Path,
    pub write_frames: bool,
}

/// Renders every camera of `cams` as `spec` says: frames (when `write_frames`), `stats.csv`,
/// `pvs.txt`, `summary.json`. Calls `tick` after each frame.
pub fn render_path(r: &mut Renderer, scene: &SceneFile, cams: &[Camera], spec: &RunSpec, tick: &dyn Fn()) -> Result<Summary, RunError> {
    let (mode, tau, out, write_frames) = (spec.mode, spec.tau, spec.out, spec.write_frames);
    if write_frames {
        std::fs::create_dir_all(out.join("frames")).map_err(OutputError::io(out))?;
    }
    let mut state = ModeState::new(mode, tau, spec.hc)?;
    state.ovc = spec.ovc;
    if !spec.always_cull {
        let pixels = r.width() as u64 * r.height() as u64;
        state.payoff = Some(osw_cull::payoff::Alternating::new(osw_cull::payoff::CullCost::at(pixels)));
    }
    let mut frames: Vec<FrameStats> = Vec::with_capacity(cams.len());
    let mut pvs = String::new();
    for (i, cam) in cams.iter().enumerate() {
        let (view, cpu) = (r.view(cam, tau), crate::stats::cpu_ms());
        let mut s = state.frame(r, scene, &view)?;
        (s.frame, s.cpu_ms) = (i as u64, crate::stats::cpu_ms() - cpu);
        frames.push(s);
        push_ids(&mut pvs, state.visible());
        if write_frames {
            write_png(&frame_path(out, i as u64), r.width(), r.height(), &r.read_color()?)?;
        }
        tick();
    }
    results::csv::write(&out.join("stats.csv"), &frames)?;
    write(&out.join("pvs.txt"), &pvs)?;
    let (header, stats) = (scene.header(), r.residency_stats());
    let summary = Summary {
        mode,
        tau,
        scene: spec.scene.display().to_string(),
        scene_hash: osw_scene::format::hash_hex(scene.content_hash()),
        path: spec.path.display().to_string(),
        width: r.width(),
        height: r.height(),
        textures: results::textures_key(scene, r.options().textures),
        of: Details::Render(RenderSummary {
            hc_test: spec.hc.name().to_owned(),
            adaptive: spec.ovc.adaptive,
            budget: spec.ovc.budget.unwrap_or(0.0),
            sampling: spec.ovc.sampling,
            adapter: r.gpu().info.name.clone(),
            uploads: stats.uploads,
            upload_bytes: stats.upload_bytes,
            upload_shared_bytes: stats.shared_bytes,
            evictions: stats.evictions,
            blocks_never_loaded: header.block_count as u64 - stats.distinct,
            blocks_total: header.block_count as u64,
            geometry_never_loaded_fraction: 1.0 - stats.distinct_bytes as f64 / header.blob_bytes.max(1) as f64,
            peak_rss_kb: crate::stats::peak_resident_kb(),
            ..RenderSummary::of(&frames)
        }),
        ..Summary::of(&frames)
    };
    summary.write(out)?;
    Ok(summary)
}

/// Exact visibility for every camera: `exact.csv` (frame, visible leaves, visible triangles,
/// triangles of the clusters holding them, triangles drawn into the item buffer, ms to draw only
/// the visible ones, and only their clusters), `exact_leaves.txt` (the visible leaves of each
/// frame) and `items/NNNNN.png` (each frame's opaque item buffer, [`crate::output::write_items`]).
pub fn exact_path(
    r: &mut Renderer,
    scene: &SceneFile,
    cams: &[Camera],
    tau: f64,
    reference: Reference,
    out: &Path,
    tick: &dyn Fn(),
) -> Result<(), RunError> {
    let mut rows = Vec::with_capacity(cams.len());
    let mut leaves = String::new();
    std::fs::create_dir_all(out.join("items")).map_err(OutputError::io(out))?;
    for (i, cam) in cams.iter().enumerate() {
        r.begin_frame();
        let view = r.view(cam, tau);
        let e = r.exact(scene, &view, tau, reference)?;
        rows.push(ExactFrame {
            frame: i as u64,
            visible_leaves: e.leaves.len() as u64,
            visible_triangles: e.triangles,
            visible_cluster_triangles: e.cluster_triangles,
            drawn_triangles: e.drawn_triangles,
            visible_draw_ms: e.visible_draw_ms,
            visible_cluster_draw_ms: e.cluster_draw_ms,
        });
        push_ids(&mut leaves, &e.leaves);
        write_items(&items_path(out, i as u64), r.width(), r.height(), &e.pixels)?;
        tick();
    }
    results::csv::write(&out.join("exact.csv"), &rows)?;
    write(&out.join("exact_leaves.txt"), &leaves)?;
    Ok(())
}
