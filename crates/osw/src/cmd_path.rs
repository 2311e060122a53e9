//! `osw path`: a camera path CSV through a scene.

use anyhow::Context;
use osw_scene::path_gen::{PathKind, PathOptions};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene file.
    #[arg(long)]
    scene: PathBuf,
    /// walk (at eye height over the model's floors, up stairs and through doorways, out of
    /// walls, on the ground floor of a building or level where there is one), orbit (around,
    /// looking at the centre) or flyover (above, looking ahead and down).
    #[arg(long)]
    kind: PathKind,
    #[arg(long, default_value_t = 300)]
    frames: u32,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Vertical field of view in degrees, in (0, 180).
    #[arg(long, default_value_t = 60.0)]
    fovy: f64,
    /// Walking speed in world units per frame.
    #[arg(long, default_value_t = 0.25)]
    speed: f64,
    /// Output CSV: frame,px,py,pz,qx,qy,qz,qw,fovy_deg.
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if !(a.speed > 0.0 && a.speed.is_finite()) {
        anyhow::bail!("--speed must be a positive number, got {}", a.speed);
    }
    let scene = osw_scene::SceneFile::open(&a.scene)?;
    let opts = PathOptions { kind: a.kind, frames: a.frames, seed: a.seed, fovy_deg: a.fovy, speed: a.speed };
    // A walk reads every leaf twice to find the floors: minutes at ten billion triangles.
    let bar = crate::progress::Bar::new();
    let cams = osw_scene::path_gen::generate(&scene, &opts, &bar);
    bar.finish();
    let cams = cams.with_context(|| a.scene.display().to_string())?;
    osw_scene::path::write(&a.output, &cams)?;
    out!("path: {:?} of {} frames → {}", a.kind, cams.len(), a.output.display());
    Ok(())
}
