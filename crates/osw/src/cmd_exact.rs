//! `osw exact`: exact visibility (item buffer) for every frame of a path: at full detail (the
//! paper's reference for PVS/exact), or with `--tau` of the scene as it is drawn at that tau
//! (the reference for culling error at that tau, apart from LOD error).

use crate::walk_args::WalkArgs;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    walk: WalkArgs,
    /// Draw the scene at this many pixels of error (0: every leaf at full detail).
    #[arg(long, default_value_t = 0.0)]
    tau: f64,
    /// Output directory: exact.csv (frame, visible_leaves, visible_triangles) and
    /// exact_leaves.txt (the visible leaves of each frame, one line per frame; at tau > 0 also
    /// groups whose HLOD is visible).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if !(a.tau >= 0.0 && a.tau.is_finite()) {
        anyhow::bail!("--tau {}: expected a finite number >= 0", a.tau);
    }
    let (cams, mut r) = a.walk.open()?;
    std::fs::create_dir_all(&a.out)?;
    let bar = crate::progress::frames(cams.len() as u64, "exact");
    let res = osw_render::run::exact_path(&mut r, &cams, a.tau, &a.out, &|| bar.inc(1));
    bar.finish_and_clear();
    res?;
    out!("exact: {} frames → {}", cams.len(), a.out.display());
    Ok(())
}
