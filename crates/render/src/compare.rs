//! `osw compare`: per-frame image error between two runs, and culling error of each run
//! against exact visibility (occlusion switch sec. 5: "PVS / exactly visible", false culling).

use osw_scene::format::{NodeKind, NodeRecord};
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

/// The LOD node each BVH node of `nodes` is drawn as in a run that drew `pvs` (LOD ids): its
/// own LOD, else the nearest ancestor's (an HLOD standing for it); `None` where neither is
/// drawn. A run's culling and LOD choice of a node are both read from this.
pub fn drawn_as(nodes: &[NodeRecord], bvh_count: usize, pvs: &[NodeId]) -> Result<Vec<Option<NodeId>>, CompareError> {
    let mut drawn = vec![None; bvh_count];
    for &id in pvs {
        let node = nodes.get(id as usize).filter(|n| n.kind() == NodeKind::Lod).ok_or(CompareError::NotALod { id, nodes: nodes.len() })?;
        drawn[node.parent as usize] = Some(id);
    }
    // BVH ids are breadth first: parents before children.
    for id in 1..bvh_count {
        if drawn[id].is_none() {
            drawn[id] = drawn[nodes[id].parent as usize];
        }
    }
    Ok(drawn)
}

/// A visible set or item buffer that does not fit the scene, or the images, it is compared with.
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
pub enum CompareError {
    #[error("id {id} is not a LOD node of this scene ({nodes} nodes): wrong scene?")]
    NotALod { id: NodeId, nodes: usize },
    #[error("id {id} is not a node of this scene ({nodes} nodes): wrong scene?")]
    NotANode { id: NodeId, nodes: usize },
    #[error("an item buffer of {items} pixels for images of {a} and {b}")]
    ItemsSize { items: usize, a: usize, b: usize },
}

/// Pixels where the two runs' RGBA8 `images` differ (in RGB) that neither culling nor LOD choice
/// explains: the nearest node there in the item buffer `items` (LOD id + 1 a pixel, 0 where
/// empty, [`crate::output::write_items`]) is drawn, and as the same LOD, by both runs
/// (`drawn`, by BVH node, from [`drawn_as`]), so the two drew it differently. Where either run
/// culled it, what lies behind shows: culling's difference. An empty pixel of the item
/// buffer can be painted only by a simplified LOD's larger outline: `empty_explained` says
/// whether the runs drew different simplified LODs.
pub fn unexplained_pixels(
    [a, b]: [&[u8]; 2],
    items: &[u32],
    nodes: &[NodeRecord],
    drawn: [&[Option<NodeId>]; 2],
    empty_explained: bool,
) -> Result<u64, CompareError> {
    if a.len() != items.len() * 4 || b.len() != items.len() * 4 {
        return Err(CompareError::ItemsSize { items: items.len(), a: a.len() / 4, b: b.len() / 4 });
    }
    let mut unexplained = 0;
    for ((p, q), &item) in a.chunks_exact(4).zip(b.chunks_exact(4)).zip(items) {
        if p[..3] == q[..3] {
            continue;
        }
        let explained = match item.checked_sub(1) {
            None => empty_explained,
            Some(id) => {
                let owner = nodes
                    .get(id as usize)
                    .filter(|n| n.kind() == NodeKind::Lod)
                    .ok_or(CompareError::NotALod { id, nodes: nodes.len() })?
                    .parent;
                let of = |d: &[Option<NodeId>]| d.get(owner as usize).copied().flatten();
                of(drawn[0]).is_none() || of(drawn[0]) != of(drawn[1])
            }
        };
        unexplained += u64::from(!explained);
    }
    Ok(unexplained)
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
pub fn cull_error(scene: &SceneFile, pvs: &[NodeId], exact_leaves: &[NodeId], exact_triangles: u64) -> Result<CullError, CompareError> {
    let n = scene.nodes();
    let bad = |id: NodeId| CompareError::NotANode { id, nodes: n.len() };
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

    /// A root group (0) over leaves 1 and 2, with LODs 3 and 4 of the leaves and the root's
    /// HLOD 5.
    fn tree() -> Vec<NodeRecord> {
        let node =
            |kind: NodeKind, parent: u32, error: f32| NodeRecord { kind: kind as u32, parent, error, ..bytemuck::Zeroable::zeroed() };
        let leaf = NodeKind::Leaf;
        vec![
            NodeRecord { first_child: 1, child_count: 2, first_lod: 5, lod_count: 1, ..node(NodeKind::Group, u32::MAX, 1.0) },
            NodeRecord { first_lod: 3, lod_count: 1, ..node(leaf, 0, 0.0) },
            NodeRecord { first_lod: 4, lod_count: 1, ..node(leaf, 0, 0.0) },
            node(NodeKind::Lod, 1, 0.0),
            node(NodeKind::Lod, 2, 0.0),
            node(NodeKind::Lod, 0, 1.0),
        ]
    }

    #[test]
    fn a_node_is_drawn_as_its_own_lod_or_its_nearest_ancestors() {
        let n = tree();
        assert_eq!(drawn_as(&n, 3, &[3, 4]).unwrap(), [None, Some(3), Some(4)]);
        assert_eq!(drawn_as(&n, 3, &[4]).unwrap(), [None, None, Some(4)]);
        assert_eq!(drawn_as(&n, 3, &[5]).unwrap(), [Some(5); 3]);
        assert_eq!(drawn_as(&n, 3, &[1]), Err(CompareError::NotALod { id: 1, nodes: 6 }));
    }

    #[test]
    fn differing_pixels_are_unexplained_where_both_runs_drew_the_node_there_alike() {
        let n = tree();
        // Three pixels, all differing: leaf 1's LOD (item 3 + 1), leaf 2's, and an empty one;
        // and a fourth, equal in both images.
        let a = [[10u8, 10, 10, 255]; 4].concat();
        let mut b = [[20u8, 10, 10, 255]; 4].concat();
        b[12..16].copy_from_slice(&[10, 10, 10, 0]);
        let items = [4, 5, 0, 4];
        let both = drawn_as(&n, 3, &[3, 4]).unwrap();
        assert_eq!(unexplained_pixels([&a, &b], &items, &n, [&both, &both], false), Ok(3));
        assert_eq!(unexplained_pixels([&a, &b], &items, &n, [&both, &both], true), Ok(2));
        // a culled leaf 2: its pixel is culling's; so it is where both culled it.
        let culled = drawn_as(&n, 3, &[3]).unwrap();
        assert_eq!(unexplained_pixels([&a, &b], &items, &n, [&culled, &both], false), Ok(2));
        assert_eq!(unexplained_pixels([&a, &b], &items, &n, [&culled, &culled], false), Ok(2));
        // a drew the root's HLOD: every pixel is LOD's.
        let hlod = drawn_as(&n, 3, &[5]).unwrap();
        assert_eq!(unexplained_pixels([&a, &b], &items, &n, [&hlod, &both], true), Ok(0));
        // Identical images: nothing to explain.
        assert_eq!(unexplained_pixels([&a, &a], &items, &n, [&both, &both], false), Ok(0));
        assert!(unexplained_pixels([&a, &b], &items[..3], &n, [&both, &both], false).is_err());
        assert!(unexplained_pixels([&a, &b], &[2, 0, 0, 0], &n, [&both, &both], false).unwrap_err().to_string().contains("not a LOD"));
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
