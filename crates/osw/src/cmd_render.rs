//! `osw render`: one culling mode over a camera path, single process.

use crate::gpu_args::GpuArgs;
use osw_render::Mode;
use osw_render::run::{RunSpec, render_path};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene file.
    #[arg(long)]
    scene: PathBuf,
    /// Camera path CSV.
    #[arg(long)]
    path: PathBuf,
    /// Culling mode: vfc (frustum only) or prev (the switch's algorithm on one GPU).
    #[arg(long)]
    mode: Mode,
    /// Pixels of error allowed by LOD selection (0 = full detail).
    #[arg(long, default_value_t = 0.0)]
    tau: f64,
    #[command(flatten)]
    gpu: GpuArgs,
    /// Do not write frame PNGs (statistics only).
    #[arg(long)]
    no_frames: bool,
    /// Output directory: frames/NNNNN.png, stats.csv, pvs.txt, summary.json.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if !(a.tau >= 0.0 && a.tau.is_finite()) {
        anyhow::bail!("--tau must be a finite number >= 0, got {}", a.tau);
    }
    let cams = osw_scene::path::read(&a.path)?;
    let mut r = a.gpu.renderer(&a.scene)?;
    std::fs::create_dir_all(&a.out)?;
    let bar = crate::progress::frames(cams.len() as u64, a.mode.name());
    let spec = RunSpec { scene: &a.scene, path: &a.path, mode: a.mode, tau: a.tau, out: &a.out, write_frames: !a.no_frames };
    let s = render_path(&mut r, &cams, &spec, &|| bar.inc(1));
    bar.finish_and_clear();
    let s = s?;
    println!(
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
