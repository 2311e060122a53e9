//! `osw render`: one culling mode over a camera path, single process.

use crate::walk_args::WalkArgs;
use osw_render::Mode;
use osw_render::pass::HcTest;
use osw_render::run::{RunSpec, render_path};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    walk: WalkArgs,
    /// Culling mode: vfc (frustum only), sw (stop and wait), chc (coherent hierarchical
    /// culling), hzb (software Z pyramid, Peng 2014), prev (the switch's algorithm on
    /// one GPU) or ovc (Bartz 1999: depth-ordered interleaved culling; see --adaptive, --budget
    /// and --sampling).
    #[arg(long)]
    mode: Mode,
    /// Pixels of error allowed by LOD selection (0 = full detail).
    #[arg(long, default_value_t = 0.0)]
    tau: f64,
    /// How prev's HC tests boxes: hybrid (the depth read back once, a farthest-depth pyramid
    /// on the CPU, then the PVS's boxes that are small on screen again, read finer), pyramid (a
    /// farthest-depth pyramid in compute, conservative, a GPU round trip per round),
    /// exact (boxes rasterised against the depth buffer, exact per pixel, with pixel counts
    /// for the LOD stop of occlusion switch sec. 4.7.2 when tau > 0) or queries (one occlusion query
    /// per box, as the paper; the slow reference).
    #[arg(long, default_value = "hybrid")]
    hc: HcTest,
    /// ovc and prev: adaptive culling's threshold (Bartz 1999 eq. 1): a box whose visible
    /// pixels, as a share of its screen rectangle and discounted by its depth, fall below it
    /// counts as occluded (prev: in HC's exact tests). 0 is off (conservative).
    #[arg(long, default_value_t = 0.0, value_name = "T")]
    adaptive: f64,
    /// ovc: cost-adaptive culling (Bartz 1999 eq. 2): occlusion tests stop after F times the
    /// previous frame's render time; the remaining nodes are only frustum culled. Off by default.
    #[arg(long, value_name = "F")]
    budget: Option<f64>,
    /// ovc: the box tests read one in S pixel lines a frame, interleaved (Bartz 1999 sec. 3.3;
    /// 1 reads all: conservative).
    #[arg(long, default_value_t = 1, value_name = "S")]
    sampling: u32,
    /// prev and chc: occlusion culling on every frame, as the papers run it. By default a frame
    /// whose occlusion culling culled fewer triangles than its occluders, tests and depth
    /// read-back cost skips it for the next frames (8, then 32, then 64, until it pays
    /// again), frustum culled only; stats.csv's `cull_skipped` and summary.json's
    /// `cull_skipped_frames` count those frames.
    #[arg(long)]
    always_cull: bool,
    /// Do not write frame PNGs (statistics only).
    #[arg(long)]
    no_frames: bool,
    /// Count the fragments RVG's draw rasterises each frame (`fragments` in stats.csv,
    /// `fragments_mean` in summary.json): on lavapipe a pass costs about its fragments. A
    /// pipeline-statistics query and a read-back a draw.
    #[arg(long)]
    fragments: bool,
    /// Time OR's and RVG's draws on the GPU with timestamps (`or_gpu_ms`, `rvg_gpu_ms` in
    /// stats.csv, their medians in summary.json): a read-back a draw, which waits for it.
    #[arg(long)]
    gpu_times: bool,
    /// Output directory: frames/NNNNN.png, stats.csv, pvs.txt, summary.json.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if !(a.tau >= 0.0 && a.tau.is_finite()) {
        anyhow::bail!("--tau must be a finite number >= 0, got {}", a.tau);
    }
    if !(a.adaptive >= 0.0 && a.adaptive.is_finite()) {
        anyhow::bail!("--adaptive must be a finite number >= 0, got {}", a.adaptive);
    }
    if a.budget.is_some_and(|f| !(f > 0.0 && f.is_finite())) {
        anyhow::bail!("--budget must be a finite number > 0, got {}", a.budget.unwrap_or_default());
    }
    if a.sampling == 0 {
        anyhow::bail!("--sampling must be at least 1");
    }
    if a.mode != Mode::Ovc && (a.budget.is_some() || a.sampling > 1) {
        anyhow::bail!("--budget and --sampling are ovc's (Bartz 1999); --mode is {}", a.mode.name());
    }
    a.mode.on_one_gpu()?;
    if !a.mode.adaptive() && a.adaptive > 0.0 {
        anyhow::bail!("--adaptive is ovc's and prev's (Bartz 1999 eq. 1); --mode is {}", a.mode.name());
    }
    let options = osw_gpu::RenderOptions { count_fragments: a.fragments, time_gpu: a.gpu_times, ..Default::default() };
    let (cams, scene, mut r) = a.walk.open(options)?;
    if a.fragments && !r.counts_fragments() {
        anyhow::bail!("--fragments: adapter {} has no pipeline statistics queries", r.gpu().info.name);
    }
    if a.gpu_times && !r.times_gpu() {
        anyhow::bail!("--gpu-times: adapter {} has no timestamp queries", r.gpu().info.name);
    }
    std::fs::create_dir_all(&a.out)?;
    let bar = crate::progress::frames(cams.len() as u64, a.mode.name());
    let spec = RunSpec {
        scene: &a.walk.scene,
        path: &a.walk.path,
        mode: a.mode,
        tau: a.tau,
        hc: a.hc,
        ovc: osw_cull::ovc::OvcOptions { adaptive: a.adaptive, budget: a.budget, sampling: a.sampling },
        always_cull: a.always_cull,
        out: &a.out,
        write_frames: !a.no_frames,
    };
    let s = render_path(&mut r, &scene, &cams, &spec, &|| bar.inc(1));
    bar.finish_and_clear();
    let s = s?;
    if let Some(d) = s.render() {
        out!(
            "left out: {} of {} geometry blocks never drawn, never read from the scene file ({:.0}% of its geometry)",
            d.blocks_never_loaded,
            d.blocks_total,
            d.geometry_never_loaded_fraction * 100.0
        );
    }
    if let Some(d) = s.render().filter(|d| d.upload_shared_bytes > 0) {
        out!(
            "stored once: {:.1} MB uploaded; nodes drew {:.1} MB more from meshes already on the GPU for another of their uses",
            d.upload_bytes as f64 / 1e6,
            d.upload_shared_bytes as f64 / 1e6
        );
    }
    if let Some((or, rvg)) = s.render().and_then(|d| d.or_gpu_ms_median.zip(d.rvg_gpu_ms_median)) {
        out!("gpu: OR's draws {or:.2} ms, RVG's {rvg:.2} ms a frame (medians, timestamps)");
    }
    if let Some(f) = s.render().and_then(|d| d.fragments_mean) {
        out!("fragments: RVG rasterised {f:.0} a frame, {:.2} a pixel", f / (s.width as f64 * s.height as f64).max(1.0));
    }
    out!(
        "left out: of the PVS's {:.0} clusters a frame, {:.0}% outside the frustum, {:.0}% facing away, {:.0}% hidden; \
         of the triangles of those drawn, {:.0} facing away and {:.0} covering no pixel centre",
        s.clusters_mean,
        s.clusters_frustum_culled_fraction * 100.0,
        s.clusters_cone_culled_fraction * 100.0,
        s.clusters_occlusion_culled_fraction * 100.0,
        s.triangles_backface_culled_mean,
        s.triangles_small_culled_mean
    );
    if s.cull_skipped_frames > 0 {
        out!(
            "left out: occlusion culling on {} of {} frames, which were frustum culled only: where it ran before them it culled fewer triangles than it cost (--always-cull keeps it on)",
            s.cull_skipped_frames,
            s.frames
        );
    }
    out!(
        "render: {} tau {} over {} frames: frame {:.1} ms median ({:.1} p95), {:.0} triangles, {:.0} nodes, {:.0} tests a frame → {}",
        s.mode,
        s.tau,
        s.frames,
        s.frame_ms_median,
        s.frame_ms_p95,
        s.triangles_drawn_mean,
        s.pvs_nodes_mean,
        s.tests_mean,
        a.out.display()
    );
    Ok(())
}
