//! `osw exact`: exact visibility (item buffer) for every frame of a path: at full detail (the
//! paper's reference for PVS/exact), or with `--tau` of the scene as it is drawn at that tau
//! (the reference for culling error at that tau, apart from LOD error). It draws the whole
//! scene and lets the GPU clip, sharing no frustum test with the modes it judges;
//! `--frustum-cut` draws vfc's cut instead (faster on large scenes).

use crate::walk_args::WalkArgs;
use osw_gpu::exact::Reference;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    walk: WalkArgs,
    /// Draw the scene at this many pixels of error (0: every leaf at full detail).
    #[arg(long, default_value_t = 0.0)]
    tau: f64,
    /// Draw only what frustum culling keeps (vfc's LOD cut) instead of the whole scene: faster
    /// on large scenes, but the reference then shares the frustum test it judges.
    #[arg(long)]
    frustum_cut: bool,
    /// Output directory: exact.csv (frame, visible_leaves, visible_triangles, drawn_triangles) and
    /// exact_leaves.txt (the visible leaves of each frame, one line per frame; at tau > 0 also
    /// groups whose HLOD is visible) and items/NNNNN.png (each frame's item buffer: at each
    /// pixel one more than the nearest LOD's id, in its four bytes, least significant in red;
    /// `osw compare` reads it to tell drawing differences from culling differences).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if !(a.tau >= 0.0 && a.tau.is_finite()) {
        anyhow::bail!("--tau {}: expected a finite number >= 0", a.tau);
    }
    let (cams, scene, mut r) = a.walk.open(Default::default())?;
    std::fs::create_dir_all(&a.out)?;
    let bar = crate::progress::frames(cams.len() as u64, "exact");
    let reference = if a.frustum_cut { Reference::FrustumCut } else { Reference::Independent };
    let res = osw_render::run::exact_path(&mut r, &scene, &cams, a.tau, reference, &a.out, &|| bar.inc(1));
    bar.finish_and_clear();
    res?;
    out!("exact: {} frames → {}", cams.len(), a.out.display());
    Ok(())
}
