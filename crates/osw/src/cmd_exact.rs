//! `osw exact`: exact visibility (item buffer at full detail) for every frame of a path.

use crate::walk_args::WalkArgs;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    walk: WalkArgs,
    /// Output directory: exact.csv (frame, visible_leaves, visible_triangles) and
    /// exact_leaves.txt (the visible leaves of each frame, one line per frame).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let (cams, mut r) = a.walk.open()?;
    std::fs::create_dir_all(&a.out)?;
    let bar = crate::progress::frames(cams.len() as u64, "exact");
    let res = osw_render::run::exact_path(&mut r, &cams, &a.out, &|| bar.inc(1));
    bar.finish_and_clear();
    res?;
    out!("exact: {} frames → {}", cams.len(), a.out.display());
    Ok(())
}
