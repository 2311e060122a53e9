//! Command-line arguments shared by the commands that render a path: scene, path, image size,
//! adapter, residency budget.

use osw_gpu::{RenderOptions, Renderer};
use osw_scene::SceneFile;
use std::path::PathBuf;

/// The default geometry residency budget, MiB.
pub const RESIDENCY_MIB: u64 = 1024;

#[derive(clap::Args, Clone)]
pub struct WalkArgs {
    /// Scene file.
    #[arg(long)]
    pub scene: PathBuf,
    /// Camera path CSV.
    #[arg(long)]
    pub path: PathBuf,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = parse_size, value_name = "WxH")]
    pub size: (u32, u32),
    /// Adapter to use: the first whose name contains this text (default: a hardware GPU if
    /// there is one, else the software one, lavapipe).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Geometry residency budget in MiB (least recently used geometry is dropped above it).
    #[arg(long, default_value_t = RESIDENCY_MIB, value_name = "MIB")]
    pub residency_mib: u64,
    /// Cluster tests of the passes that draw: a list of `frustum`, `cone` (per cluster),
    /// `backface`, `small` (per triangle of a cluster drawn) and `occlusion` (prev: the clusters
    /// HC's pyramid hides, left out by RVG), or `none` (exact
    /// visibility's item pass always draws every triangle).
    #[arg(long, default_value_t = osw_cull::cluster::ClusterTests::default(), value_name = "LIST")]
    pub cluster_tests: osw_cull::cluster::ClusterTests,
    /// Draw textured surfaces in each texture's mean colour instead of sampling it.
    #[arg(long)]
    pub no_textures: bool,
}

pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("{s:?}: expected WIDTHxHEIGHT, e.g. 1024x1024"))?;
    let parse = |t: &str| t.trim().parse::<u32>().map_err(|_| format!("{s:?}: {t:?} is not a whole number"));
    let (w, h) = (parse(w)?, parse(h)?);
    let max = osw_gpu::limits::MAX_SIZE;
    if w == 0 || h == 0 || w > max || h > max {
        return Err(format!("{s:?}: each side must be 1..={max}"));
    }
    Ok((w, h))
}

impl WalkArgs {
    /// Reads the path, opens the scene and a renderer for it with `options` and these
    /// cluster tests and residency budget.
    pub fn open(&self, options: RenderOptions) -> anyhow::Result<(Vec<osw_scene::Camera>, SceneFile, Renderer)> {
        let cams = osw_scene::path::read(&self.path)?;
        let scene = SceneFile::open(&self.scene)?;
        let gpu = osw_gpu::Gpu::new(self.adapter.as_deref())?;
        tracing::info!("adapter: {} ({:?})", gpu.info.name, gpu.info.device_type);
        let options = RenderOptions {
            cluster_tests: self.cluster_tests,
            residency_bytes: self.residency_mib << 20,
            textures: !self.no_textures,
            ..options
        };
        let r = Renderer::new(gpu, &scene, self.size.0, self.size.1, options)?;
        Ok((cams, scene, r))
    }
}
