//! `osw compare`: per-frame image error between two runs, and culling error of each run
//! against exact visibility (occlusion switch sec. 5: "PVS / exactly visible", false culling).

use osw_scene::format::NodeKind;
use osw_scene::{NodeId, SceneFile};
use serde::Serialize;

/// Image error between two RGBA8 images of the same size.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ImageError {
    /// Peak signal-to-noise ratio over RGB in dB; `None` when the images are identical.
    pub psnr_db: Option<f64>,
    /// Fraction of pixels whose RGB differs at all.
    pub differing_fraction: f64,
    /// Largest difference of one channel (0..=255).
    pub max_channel_diff: u8,
}

/// `a` and `b` are RGBA8 pixels of the same image size; alpha is ignored.
pub fn image_error(a: &[u8], b: &[u8]) -> ImageError {
    let (mut sq, mut differing, mut max) = (0u64, 0u64, 0u8);
    for (p, q) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        let mut any = false;
        for k in 0..3 {
            let d = p[k].abs_diff(q[k]);
            sq += d as u64 * d as u64;
            max = max.max(d);
            any |= d != 0;
        }
        differing += any as u64;
    }
    let pixels = (a.len() / 4).max(1) as f64;
    let mse = sq as f64 / (pixels * 3.0);
    ImageError {
        psnr_db: (mse > 0.0).then(|| 10.0 * (255.0 * 255.0 / mse).log10()),
        differing_fraction: differing as f64 / pixels,
        max_channel_diff: max,
    }
}

/// Pixels of `a` and `b` (RGBA8, the same size) where a channel of RGB differs by more than
/// `above` levels.
pub fn changed_pixels(a: &[u8], b: &[u8], above: u8) -> u64 {
    a.chunks_exact(4).zip(b.chunks_exact(4)).filter(|(p, q)| (0..3).any(|k| p[k].abs_diff(q[k]) > above)).count() as u64
}

/// Culling error of one frame against exact visibility.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct CullError {
    /// Exactly visible leaves that the PVS does not draw (neither their own LOD nor an
    /// ancestor's HLOD): must be 0 for a conservative method at tau = 0. Against exact
    /// visibility at the run's tau (`osw exact --tau`), whose visible nodes include groups
    /// shown by their HLOD, a group counts as drawn when the PVS draws it or anything under
    /// it: then it must be 0 at every tau.
    pub false_culled_leaves: u32,
    /// Leaves the PVS draws at one of their own LODs, plus exactly visible leaves it covers
    /// with an ancestor's HLOD (an HLOD stands for the leaves it covers, so the hidden ones
    /// under it are not counted against the culling).
    pub pvs_leaves: u32,
    pub exact_leaves: u32,
    /// Triangles the PVS draws over exactly visible triangles.
    pub pvs_triangles: u64,
    pub exact_triangles: u64,
}

impl CullError {
    pub fn leaf_ratio(&self) -> f64 {
        self.pvs_leaves as f64 / self.exact_leaves.max(1) as f64
    }

    pub fn triangle_ratio(&self) -> f64 {
        self.pvs_triangles as f64 / self.exact_triangles.max(1) as f64
    }
}

/// Compares a drawn set (LOD ids) with the exactly visible leaves of the same frame.
pub fn cull_error(scene: &SceneFile, pvs: &[NodeId], exact_leaves: &[NodeId], exact_triangles: u64) -> Result<CullError, String> {
    let n = scene.nodes();
    let bad = |id: NodeId| format!("id {id} is not a node of this scene ({} nodes): wrong scene?", n.len());
    // Mark the BVH owners of drawn LODs, then every node under a marked node.
    let mut drawn = vec![false; scene.bvh_count() as usize];
    let mut pvs_triangles = 0;
    for &id in pvs {
        let node = n.get(id as usize).filter(|x| x.kind() == NodeKind::Lod).ok_or_else(|| bad(id))?;
        drawn[node.parent as usize] = true;
        pvs_triangles += node.triangles;
    }
    // BVH ids are breadth first: parents before children. covered: drawn or under a drawn
    // node; below: a node under it is drawn.
    let mut covered = drawn.clone();
    for id in 1..covered.len() {
        covered[id] |= covered[n[id].parent as usize];
    }
    let mut below = vec![false; drawn.len()];
    for id in (1..drawn.len()).rev() {
        below[n[id].parent as usize] |= drawn[id] || below[id];
    }
    let own = (0..drawn.len()).filter(|&i| drawn[i] && n[i].kind() == NodeKind::Leaf).count() as u32;
    let mut false_culled = 0;
    let mut under_hlod = 0;
    for &leaf in exact_leaves {
        let (l, c) = (leaf as usize, *covered.get(leaf as usize).ok_or_else(|| bad(leaf))?);
        match c || below[l] {
            false => false_culled += 1,
            true if !drawn[l] && !below[l] => under_hlod += 1,
            true => {}
        }
    }
    let pvs_leaves = own + under_hlod;
    Ok(CullError { false_culled_leaves: false_culled, pvs_leaves, exact_leaves: exact_leaves.len() as u32, pvs_triangles, exact_triangles })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_and_different_images() {
        let a = vec![10u8, 20, 30, 255, 0, 0, 0, 255];
        assert_eq!(image_error(&a, &a), ImageError { psnr_db: None, differing_fraction: 0.0, max_channel_diff: 0 });
        let mut b = a.clone();
        b[0] = 13; // one channel of one pixel off by 3: mse = 9 / 6
        let e = image_error(&a, &b);
        assert_eq!(e.differing_fraction, 0.5);
        assert_eq!(e.max_channel_diff, 3);
        assert!((e.psnr_db.unwrap() - 10.0 * (255.0f64 * 255.0 / 1.5).log10()).abs() < 1e-9);
    }

    #[test]
    fn changed_pixels_count_channels_over_the_threshold_and_ignore_alpha() {
        let a = vec![10u8, 20, 30, 255, 0, 0, 0, 255, 100, 100, 100, 255];
        let mut b = a.clone();
        (b[1], b[4], b[11]) = (22, 3, 0); // pixel 0 off by 2, pixel 1 by 3, pixel 2 in alpha only
        assert_eq!(changed_pixels(&a, &b, 2), 1);
        assert_eq!(changed_pixels(&a, &b, 1), 2);
        assert_eq!(changed_pixels(&a, &a, 0), 0);
    }
}
