//! `osw exact`: exact visibility (item buffer at full detail) for every frame of a path.

use crate::gpu_args::GpuArgs;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(long)]
    scene: PathBuf,
    #[arg(long)]
    path: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
    /// Output directory: exact.csv (frame, visible_leaves, visible_triangles) and
    /// exact_leaves.txt (the visible leaves of each frame, one line per frame).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let cams = osw_scene::path::read(&a.path)?;
    let mut r = a.gpu.renderer(&a.scene)?;
    std::fs::create_dir_all(&a.out)?;
    let bar = crate::progress::frames(cams.len() as u64, "exact");
    let res = osw_render::run::exact_path(&mut r, &cams, &a.out, &|| bar.inc(1));
    bar.finish_and_clear();
    res?;
    println!("exact: {} frames → {}", cams.len(), a.out.display());
    Ok(())
}
