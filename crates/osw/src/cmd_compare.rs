//! `osw compare`: image error between two runs frame by frame and, given `osw exact` output,
//! each run's culling error (false-culled leaves, PVS/exact for leaves and triangles), and with
//! `--popping` each run's temporal error (osw_render::popping).

use crate::walk_args::WalkArgs;
use anyhow::{Context, bail};
use osw_render::compare::{CullError, ImageError, cull_error, drawn_as, image_error, unexplained_pixels};
use osw_render::output::{frame_path, items_path, read_ids, read_items, read_png};
use osw_render::popping::popping;
use osw_render::results::{self, Compare, Culling, DisplayFrame, ExactFrame, Popping, Summary};
use osw_render::stats::mean;
use osw_render::{FrameStats, Mode};
use osw_scene::format::NodeKind;
use osw_scene::{NodeId, SceneFile};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// A run directory (of `osw render` or `osw run`).
    #[arg(long)]
    a: PathBuf,
    /// The run to compare it with (e.g. vfc at tau 0, the reference image).
    #[arg(long)]
    b: PathBuf,
    /// `osw exact` output for the same scene and path: adds culling error, and which
    /// differing pixels neither run's culling or LOD explains (`unexplained_pixels`: the node
    /// nearest there in the item buffer was drawn as the same LOD by both).
    #[arg(long)]
    exact: Option<PathBuf>,
    /// `osw exact --tau T` output at the runs' tau: false culling counted against what is
    /// visible at that tau, culling error apart from LOD error (0 for a conservative method).
    #[arg(long, requires = "exact")]
    exact_lod: Option<PathBuf>,
    /// Temporal error of each run: the pixels that pop when each frame's visible set is drawn
    /// with the previous camera's choice of detail (osw_render::popping). Draws every frame
    /// twice more, with the scene, path and size each run's summary names.
    #[arg(long)]
    popping: bool,
    /// Output directory: compare.json and compare.csv.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Default)]
struct FrameRow {
    frame: usize,
    image: Option<ImageError>,
    unexplained: Option<u64>,
    a: Option<CullError>,
    b: Option<CullError>,
    popping: [Option<f64>; 2],
}

/// A line of compare.csv: a frame's image error and each run's culling error, empty where
/// there is nothing to compare.
#[derive(serde::Serialize, Default)]
struct CompareRow {
    frame: usize,
    psnr_db: Option<f64>,
    differing_fraction: f64,
    max_channel_diff: u8,
    unexplained_pixels: Option<u64>,
    a_false_culled: Option<u32>,
    a_leaf_ratio: Option<f64>,
    a_triangle_ratio: Option<f64>,
    b_false_culled: Option<u32>,
    b_leaf_ratio: Option<f64>,
    b_triangle_ratio: Option<f64>,
    a_popping_fraction: Option<f64>,
    b_popping_fraction: Option<f64>,
}

fn side(errors: &[CullError]) -> Culling {
    let n = errors.len().max(1) as f64;
    Culling {
        false_culled_leaves_total: errors.iter().map(|e| e.false_culled_leaves as u64).sum(),
        frames_with_false_culling: errors.iter().filter(|e| e.false_culled_leaves > 0).count() as u64,
        pvs_exact_leaves_ratio_mean: errors.iter().map(CullError::leaf_ratio).sum::<f64>() / n,
        pvs_exact_triangles_ratio_mean: errors.iter().map(CullError::triangle_ratio).sum::<f64>() / n,
        ..Culling::default()
    }
}

/// The triangles a run drew each frame (its stats.csv: the display's for the switch), if it
/// wrote them.
fn triangles_drawn(dir: &Path, s: &Summary) -> anyhow::Result<Option<Vec<u64>>> {
    let path = dir.join("stats.csv");
    if !path.exists() {
        return Ok(None);
    }
    Ok(Some(match s.mode {
        Mode::Switch => results::csv::read::<DisplayFrame>(&path)?.iter().map(|f| f.triangles_drawn).collect(),
        _ => results::csv::read::<FrameStats>(&path)?.iter().map(|f| f.triangles_drawn).collect(),
    }))
}

/// The visible sets of the run in `dir` (its pvs.txt), at least `frames` of them.
fn read_pvs(dir: &Path, frames: usize) -> anyhow::Result<Vec<Vec<NodeId>>> {
    let pvs = read_ids(&dir.join("pvs.txt"))?;
    if pvs.len() < frames {
        bail!("{}: pvs.txt has {} frames, summary.json says {frames}", dir.display(), pvs.len());
    }
    Ok(pvs)
}

/// Each frame's popping (osw_render::popping) in the run in `dir`, none for frame 0 (no frame
/// before it): its visible sets drawn again with the scene, path, size and tau its summary names.
fn popping_of(dir: &Path, s: &Summary, frames: usize) -> anyhow::Result<Vec<Option<f64>>> {
    let pvs = read_pvs(dir, frames)?;
    let walk = WalkArgs {
        scene: s.scene.clone().into(),
        path: s.path.clone().into(),
        size: (s.width, s.height),
        adapter: None,
        residency_mib: crate::walk_args::RESIDENCY_MIB,
        cluster_tests: Default::default(),
        no_textures: false,
    };
    let (cams, scene, mut r) = walk.open(Default::default()).with_context(|| format!("drawing {} again", dir.display()))?;
    if cams.len() < frames {
        bail!("{}: {} cameras, the runs have {frames} frames", s.path, cams.len());
    }
    let lod = |id: &u32| scene.nodes().get(*id as usize).is_some_and(|n| n.kind() == NodeKind::Lod);
    if let Some((i, id)) = pvs[..frames].iter().enumerate().find_map(|(i, ids)| Some((i, ids.iter().find(|id| !lod(id))?))) {
        bail!("{}: frame {i} names node {id}, which is not a LOD of {}", dir.join("pvs.txt").display(), s.scene);
    }
    let bar = crate::progress::frames(frames as u64, "popping");
    let (mut out, mut scratch) = (vec![None], Vec::new());
    for i in 1..frames {
        r.begin_frame();
        let (before, now) = (r.view(&cams[i - 1], s.tau), r.view(&cams[i], s.tau));
        out.push(Some(popping(&mut r, &scene, &before, &now, &pvs[i], s.tau, &mut scratch)?));
        bar.inc(1);
    }
    bar.finish_and_clear();
    out.truncate(frames);
    Ok(out)
}

/// What tells the two runs' drawing differences from their culling and LOD differences
/// (osw_render::compare::unexplained_pixels): the reference's item buffers and each run's
/// visible sets.
struct Attribution {
    scene: SceneFile,
    items: PathBuf,
    pvs: [Vec<Vec<NodeId>>; 2],
}

impl Attribution {
    /// None when `reference` has no item buffers (written by an osw before they were).
    fn of(scene: &Path, reference: &Path, runs: [&Path; 2], frames: usize) -> anyhow::Result<Option<Attribution>> {
        if !items_path(reference, 0).exists() {
            return Ok(None);
        }
        if frames > 0 && !items_path(reference, frames as u64 - 1).exists() {
            bail!("{}: item buffers for fewer frames than the runs' {frames}", reference.display());
        }
        let pvs = [read_pvs(runs[0], frames)?, read_pvs(runs[1], frames)?];
        Ok(Some(Attribution { scene: SceneFile::open(scene)?, items: reference.to_path_buf(), pvs }))
    }

    /// Frame `i`'s unexplained pixels between the two runs' RGBA8 `images` of `size`.
    fn frame(&self, i: usize, images: [&[u8]; 2], size: (u32, u32)) -> anyhow::Result<u64> {
        let path = items_path(&self.items, i as u64);
        let (w, h, items) = read_items(&path)?;
        if (w, h) != size {
            bail!("{}: {w}x{h}, the frames are {}x{}", path.display(), size.0, size.1);
        }
        let nodes = self.scene.nodes();
        let bvh = self.scene.bvh_count() as usize;
        let (pa, pb) = (&self.pvs[0][i], &self.pvs[1][i]);
        let drawn = [drawn_as(nodes, bvh, pa), drawn_as(nodes, bvh, pb)].map(|d| d.map_err(anyhow::Error::msg));
        let [da, db] = drawn;
        let simplified = |p: &[NodeId]| p.iter().copied().filter(|&id| nodes[id as usize].error > 0.0).collect::<Vec<_>>();
        let empty_explained = simplified(pa) != simplified(pb);
        unexplained_pixels(images, &items, nodes, [&da?, &db?], empty_explained).with_context(|| path.display().to_string())
    }
}

/// `osw exact` output: the visible nodes and the exact.csv row of each of `frames` frames.
fn read_exact(dir: &Path, frames: usize) -> anyhow::Result<(Vec<Vec<u32>>, Vec<ExactFrame>)> {
    let leaves = read_ids(&dir.join("exact_leaves.txt"))?;
    let rows: Vec<ExactFrame> = results::csv::read(&dir.join("exact.csv"))?;
    if leaves.len() < frames || rows.len() < frames {
        bail!("{} has {} frames, the runs have {frames}", dir.display(), leaves.len().min(rows.len()));
    }
    Ok((leaves, rows))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let (sa, sb) = (Summary::read(&a.a)?, Summary::read(&a.b)?);
    if sa.scene_hash != sb.scene_hash {
        bail!("{} and {} were rendered from different scenes ({} vs {})", a.a.display(), a.b.display(), sa.scene_hash, sb.scene_hash);
    }
    let frames = sa.frames.min(sb.frames) as usize;
    let mut rows: Vec<FrameRow> = (0..frames).map(|frame| FrameRow { frame, ..Default::default() }).collect();
    let (ms_a, ms_b) = (sa.frame_ms_median, sb.frame_ms_median);
    let mut report = Compare {
        a: a.a.display().to_string(),
        b: a.b.display().to_string(),
        frames,
        frame_ms_median_a: ms_a,
        frame_ms_median_b: ms_b,
        speedup_a_over_b: ms_b / ms_a.max(1e-9),
        ..Default::default()
    };
    compare_images(&a, &sa, &mut rows, &mut report)?;
    if let Some(exact) = &a.exact {
        compare_culling(&a, exact, [&sa, &sb], &mut rows, &mut report)?;
    }
    if a.popping {
        for (k, (dir, s)) in [(&a.a, &sa), (&a.b, &sb)].into_iter().enumerate() {
            let popping = popping_of(dir, s, frames)?;
            for (row, p) in rows.iter_mut().zip(&popping) {
                row.popping[k] = *p;
            }
            let p: Vec<f64> = popping.into_iter().flatten().collect();
            let side = Popping { fraction_mean: mean(p.iter().copied()), fraction_max: p.iter().copied().fold(0.0, f64::max) };
            if k == 0 { report.popping_a = Some(side) } else { report.popping_b = Some(side) }
        }
    }
    std::fs::create_dir_all(&a.out)?;
    results::write_json(&a.out.join("compare.json"), &report)?;
    let csv: Vec<CompareRow> = rows.iter().map(FrameRow::csv).collect();
    results::csv::write(&a.out.join("compare.csv"), &csv)?;
    print(&report, [&sa, &sb], rows.iter().any(|r| r.image.is_some()), &a.out);
    Ok(())
}

/// Image error frame by frame, where both runs wrote frames, and with a reference's item
/// buffers the pixels that neither culling nor LOD explains.
fn compare_images(a: &Args, sa: &Summary, rows: &mut [FrameRow], report: &mut Compare) -> anyhow::Result<()> {
    if !(frame_path(&a.a, 0).exists() && frame_path(&a.b, 0).exists()) {
        return Ok(());
    }
    // The reference at the runs' tau where it has item buffers, else the one at full detail.
    let mut attribution = None;
    for reference in [a.exact_lod.as_deref(), a.exact.as_deref()].into_iter().flatten() {
        attribution = attribution.or(Attribution::of(Path::new(&sa.scene), reference, [&a.a, &a.b], rows.len())?);
    }
    for row in rows.iter_mut() {
        let (wa, ha, pa) = read_png(&frame_path(&a.a, row.frame as u64))?;
        let (wb, hb, pb) = read_png(&frame_path(&a.b, row.frame as u64))?;
        if (wa, ha) != (wb, hb) {
            bail!("frame {}: {wa}x{ha} in {} but {wb}x{hb} in {}", row.frame, a.a.display(), a.b.display());
        }
        row.image = Some(image_error(&pa, &pb));
        row.unexplained = attribution.as_ref().map(|at| at.frame(row.frame, [&pa, &pb], (wa, ha))).transpose()?;
    }
    let images: Vec<ImageError> = rows.iter().filter_map(|r| r.image).collect();
    let mut psnr: Vec<f64> = images.iter().filter_map(|i| i.psnr_db).collect();
    psnr.sort_by(f64::total_cmp);
    report.identical_frames = images.iter().filter(|i| i.psnr_db.is_none()).count();
    report.psnr_db_min = psnr.first().copied();
    report.psnr_db_median = (!psnr.is_empty()).then(|| psnr[psnr.len() / 2]);
    report.differing_fraction_mean = images.iter().map(|i| i.differing_fraction).sum::<f64>() / images.len().max(1) as f64;
    report.differing_fraction_max = images.iter().map(|i| i.differing_fraction).fold(0.0, f64::max);
    report.max_channel_diff = images.iter().map(|i| i.max_channel_diff).max().unwrap_or(0);
    report.unexplained_pixels = attribution.is_some().then(|| rows.iter().filter_map(|r| r.unexplained).sum());
    Ok(())
}

/// Each run's culling error against `exact` (and `--exact-lod`), frame by frame, and the
/// floors exact visibility gives.
fn compare_culling(a: &Args, exact: &Path, summaries: [&Summary; 2], rows: &mut [FrameRow], report: &mut Compare) -> anyhow::Result<()> {
    let frames = rows.len();
    let scene = osw_scene::SceneFile::open(Path::new(&summaries[0].scene))?;
    let (leaves, rows_exact) = read_exact(exact, frames)?;
    let tris: Vec<u64> = rows_exact.iter().map(|r| r.visible_triangles).collect();
    let floor: Option<Vec<f64>> =
        rows_exact[..frames].iter().map(|r| r.visible_cluster_triangles.map(|c| c as f64 / r.visible_triangles.max(1) as f64)).collect();
    report.cluster_exact_triangles_ratio_mean = floor.map(|f| f.iter().sum::<f64>() / frames.max(1) as f64);
    let lod = a.exact_lod.as_deref().map(|d| read_exact(d, frames)).transpose()?;
    // RVG's floor at the runs' tau: the LOD reference's, if given.
    let floor_rows = lod.as_ref().map_or(&rows_exact, |(_, rows)| rows);
    let median = |ms: Option<Vec<f64>>| ms.filter(|v| !v.is_empty()).map(|v| osw_render::stats::quantile(&v, 0.5));
    report.visible_draw_ms_median = median(floor_rows[..frames].iter().map(|r| r.visible_draw_ms).collect());
    report.visible_cluster_draw_ms_median = median(floor_rows[..frames].iter().map(|r| r.visible_cluster_draw_ms).collect());
    for (which, dir) in [(0, &a.a), (1, &a.b)] {
        let pvs = read_pvs(dir, frames)?;
        let mut errs = Vec::with_capacity(frames);
        for row in rows.iter_mut() {
            let e = cull_error(&scene, &pvs[row.frame], &leaves[row.frame], tris[row.frame])?;
            errs.push(e);
            if which == 0 { row.a = Some(e) } else { row.b = Some(e) }
        }
        let mut s = side(&errs);
        if let Some(drawn) = triangles_drawn(dir, summaries[which])? {
            s.drawn_exact_triangles_ratio_mean =
                Some(drawn.iter().zip(&tris).take(frames).map(|(&d, &t)| d as f64 / t.max(1) as f64).sum::<f64>() / frames.max(1) as f64);
        }
        if let (Some((lod_leaves, lod_rows)), Some(lod_dir)) = (&lod, &a.exact_lod) {
            let mut missed = Vec::with_capacity(frames);
            for f in 0..frames {
                let e = cull_error(&scene, &pvs[f], &lod_leaves[f], lod_rows[f].visible_triangles)?;
                missed.push(e.false_culled_leaves as u64);
            }
            s.lod_false_culled_total = Some(missed.iter().sum());
            s.lod_frames_with_false_culling = Some(missed.iter().filter(|&&m| m > 0).count() as u64);
            s.lod_not_drawn_total = lods_not_drawn(lod_dir, &pvs[..frames])?;
        }
        if which == 0 { report.culling_a = Some(s) } else { report.culling_b = Some(s) }
    }
    report.exact = Some(exact.display().to_string());
    Ok(())
}

/// LOD nodes the item buffers in `reference` show that `pvs` does not hold, summed over the
/// frames; None where the reference wrote no item buffers.
fn lods_not_drawn(reference: &Path, pvs: &[Vec<NodeId>]) -> anyhow::Result<Option<u64>> {
    if !items_path(reference, 0).exists() {
        return Ok(None);
    }
    let mut total = 0;
    for (i, drawn) in pvs.iter().enumerate() {
        let mut drawn = drawn.clone();
        drawn.sort_unstable();
        let path = items_path(reference, i as u64);
        let (_, _, mut items) = read_items(&path).with_context(|| path.display().to_string())?;
        items.sort_unstable();
        items.dedup();
        // An item is a LOD node's id plus one, 0 where nothing is drawn.
        total += items.iter().filter(|&&item| item != 0 && drawn.binary_search(&(item - 1)).is_err()).count() as u64;
    }
    Ok(Some(total))
}

impl FrameRow {
    /// The frame's line of compare.csv.
    fn csv(&self) -> CompareRow {
        let i = self.image.unwrap_or_default();
        CompareRow {
            frame: self.frame,
            // Identical frames: infinite PSNR; no image to compare: empty.
            psnr_db: self.image.map(|i| i.psnr_db.unwrap_or(f64::INFINITY)),
            differing_fraction: i.differing_fraction,
            max_channel_diff: i.max_channel_diff,
            unexplained_pixels: self.unexplained,
            a_false_culled: self.a.map(|e| e.false_culled_leaves),
            a_leaf_ratio: self.a.map(|e| e.leaf_ratio()),
            a_triangle_ratio: self.a.map(|e| e.triangle_ratio()),
            b_false_culled: self.b.map(|e| e.false_culled_leaves),
            b_leaf_ratio: self.b.map(|e| e.leaf_ratio()),
            b_triangle_ratio: self.b.map(|e| e.triangle_ratio()),
            a_popping_fraction: self.popping[0],
            b_popping_fraction: self.popping[1],
        }
    }
}

/// The comparison in one line.
fn print(report: &Compare, [sa, sb]: [&Summary; 2], images: bool, out: &Path) {
    let image = if !images {
        "no frames to compare".to_string()
    } else {
        format!(
            "{} identical, PSNR min {}, differing pixels up to {:.4}%{}",
            report.identical_frames,
            report.psnr_db_min.map_or("inf".into(), |p| format!("{p:.1} dB")),
            report.differing_fraction_max * 100.0,
            report.unexplained_pixels.map_or(String::new(), |n| format!(" ({n} drawn differently, not culled)"))
        )
    };
    out!(
        "compare: {} frames, {image}; a {:.1} ms a frame (median), b {:.1} ms: a is {:.2}x as fast{}{}{}{} → {}",
        report.frames,
        report.frame_ms_median_a,
        report.frame_ms_median_b,
        report.speedup_a_over_b,
        report.culling_a.as_ref().map_or(String::new(), |s| format!(
            ", a: {} false-culled leaves{}, PVS/exact leaves {:.2}{}",
            s.false_culled_leaves_total,
            s.lod_false_culled_total.map_or(String::new(), |n| format!(
                " ({n} against visibility at its tau, {} visible LODs not drawn at their level)",
                s.lod_not_drawn_total.unwrap_or(0)
            )),
            s.pvs_exact_leaves_ratio_mean,
            s.drawn_exact_triangles_ratio_mean.map_or(String::new(), |r| format!(", drawn/exact triangles {r:.1}"))
        )),
        report.cluster_exact_triangles_ratio_mean.map_or(String::new(), |r| format!(" (at least {r:.1} culling whole clusters)")),
        report.visible_draw_ms_median.map_or(String::new(), |f| format!(
            "; RVG a {:.1} ms a frame (median), b {:.1}: drawing only the visible triangles takes {f:.1}{}",
            sa.rvg_ms_median,
            sb.rvg_ms_median,
            report.visible_cluster_draw_ms_median.map_or(String::new(), |c| format!(", only their clusters {c:.1}"))
        )),
        match (&report.popping_a, &report.popping_b) {
            (Some(pa), Some(pb)) =>
                format!("; popping a {:.3}% of pixels a frame (mean), b {:.3}%", pa.fraction_mean * 100.0, pb.fraction_mean * 100.0),
            _ => String::new(),
        },
        out.display()
    );
}
