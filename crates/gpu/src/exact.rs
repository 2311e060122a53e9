//! Exact visibility by item buffer (occlusion switch sec. 5): the scene drawn with each LOD node's id
//! and each triangle's index; the ids left in the image are exactly the visible nodes and
//! triangles at this resolution. At tau 0 that is every leaf at full detail (the paper's
//! reference); at tau > 0 it is the image a person sees at that tau, so that culling error can
//! be told apart from LOD error.
//!
//! The reference shares nothing with the culling it judges ([`Reference::Independent`]): at tau
//! 0 it draws every leaf's level 0, found by scanning the node table, and lets the GPU clip; at
//! tau > 0 it picks each node's level from the node table and the eye alone
//! ([`independent_cut`]). [`Reference::FrustumCut`] draws the cut frustum culling makes (faster
//! on large scenes, but a frustum bug and the traversal's cut selection are then shared).

use crate::draw::{Layer, Load, Pass};
use crate::renderer::{RenderError, Renderer};
use osw_cull::cluster::ClusterTests;
use osw_cull::{View, frustum_cull};
use osw_scene::{NodeId, NodeKind, SceneFile};
use std::ops::Range;

/// What the item buffer draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// Everything, clipped by the GPU: no CPU frustum test, at tau 0 no traversal either.
    Independent,
    /// The frustum-culled LOD cut, as `vfc` draws it.
    FrustumCut,
}

/// Exact visibility of one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExactFrame {
    /// BVH nodes whose geometry is visible, sorted: leaves, and at tau > 0 also groups shown
    /// by their HLOD.
    pub leaves: Vec<NodeId>,
    /// Distinct visible triangles (a translucent one counts where it is the nearest translucent
    /// surface in some pixel).
    pub triangles: u64,
    /// Triangles of the clusters that hold a visible triangle: the fewest that culling whole
    /// clusters can draw, however exact its tests. `None` when the item buffer was
    /// drawn in more than one call (a triangle's index then restarts).
    pub cluster_triangles: Option<u64>,
    /// Triangles drawn into the item buffer (the scene's full-detail count for the independent
    /// reference at tau 0).
    pub drawn_triangles: u64,
    /// Milliseconds to draw in colour only the visible triangles, submit to done: the least
    /// any culling lets RVG's draw take at this size and tau. Drawn last: its image
    /// is the item pass's, in colour (`Renderer::read_color`). `None` like `cluster_triangles`.
    pub visible_draw_ms: Option<f64>,
    /// The same for the triangles of `cluster_triangles`: the least culling whole clusters
    /// lets RVG's draw take.
    pub cluster_draw_ms: Option<f64>,
    /// The opaque item buffer, rows top first: the LOD node id + 1 nearest at each pixel, 0
    /// where nothing is (translucent surfaces over a pixel are left out).
    pub pixels: Vec<u32>,
}

/// The LOD nodes the item buffer draws.
fn drawn(scene: &SceneFile, view: &View, tau: f64, reference: Reference) -> Vec<NodeId> {
    let mut ids = Vec::new();
    match reference {
        Reference::Independent if tau == 0.0 => {
            ids.extend((0..scene.bvh_count()).map(|id| scene.node(id)).filter(|n| n.kind() == NodeKind::Leaf).map(|n| n.first_lod))
        }
        Reference::Independent => ids = independent_cut(scene, view.eye, view.focal_px, tau),
        Reference::FrustumCut => {
            frustum_cull(scene.nodes(), view, tau, &mut ids);
        }
    }
    // Sorted: where two surfaces tie in depth the first drawn keeps the pixel.
    ids.sort_unstable();
    ids
}

/// The LOD cut at `tau` made from the node table and the eye alone, per BVH node and without
/// a traversal or any test of `osw_cull` (whose cut selection it judges): a node is reached
/// when its parent is reached and neither stands for it with a static LOD or HLOD within tau
/// nor holds a cluster hierarchy coarse enough below (occlusion switch sec. 4.1: the coarsest
/// level within tau). A node reached draws its coarsest static level within tau, else its cut
/// node where the cut may take a cluster of it.
fn independent_cut(scene: &SceneFile, eye: glam::DVec3, focal_px: f64, tau: f64) -> Vec<NodeId> {
    let nodes = scene.nodes();
    // Pixels of `error` on geometry in `b`: the error over the distance to the box, times the
    // focal length; unbounded with the eye in the box.
    let px = |error: f32, b: &osw_scene::Aabb| {
        let d = (b.min.as_dvec3() - eye).max(eye - b.max.as_dvec3()).max(glam::DVec3::ZERO).length();
        if error <= 0.0 {
            0.0
        } else if d <= 0.0 {
            f64::INFINITY
        } else {
            error as f64 * focal_px / d
        }
    };
    let lod = osw_scene::error_metric::LodView { eye, focal_px, tau };
    let mut reached = vec![false; scene.bvh_count() as usize];
    reached[scene.root() as usize] = true;
    let mut cut = Vec::new();
    // BVH ids are breadth first: a parent is decided before its children.
    for id in 0..reached.len() {
        if !reached[id] {
            continue;
        }
        let n = &nodes[id];
        let b = n.aabb();
        if let Some(l) = n.lods().rev().find(|&l| !nodes[l as usize].is_cut() && px(nodes[l as usize].error, &b) <= tau) {
            cut.push(l);
            continue;
        }
        cut.extend(n.lods().find(|&l| nodes[l as usize].is_cut() && lod.may_take(&nodes[l as usize])));
        if n.kind() == NodeKind::Group && (!n.is_bounded() || n.cut_hi.px(eye, focal_px) > tau) {
            n.children().for_each(|c| reached[c as usize] = true);
        }
    }
    cut
}

impl Renderer {
    pub fn exact(&mut self, scene: &SceneFile, view: &View, tau: f64, reference: Reference) -> Result<ExactFrame, RenderError> {
        let ids = drawn(scene, view, tau, reference);
        let drawn = self.draw(scene, view, &ids, Pass::Item, Load::Clear)?;
        let pass = std::mem::take(&mut self.indices);
        let read = self.target.read_item(&self.gpu)?;
        let pixels: Vec<u32> = read.iter().map(|i| i[0]).collect();
        let items = distinct(read);
        let mut leaves: Vec<NodeId> = items.iter().map(|i| scene.node(i[0] - 1).parent).collect();
        // Translucent surfaces and cut-outs are not in the depth buffer: what lies behind them
        // was found above. They are visible where a triangle of theirs passes the depth test; a
        // pass keeps only the last of overlapping ones, so passes repeat without the nodes
        // found until one finds none.
        let mut translucent: Vec<NodeId> = ids.iter().copied().filter(|&id| scene.has_see_through(id)).collect();
        let (mut translucent_triangles, mut drawn_triangles, mut first) = (0, drawn.triangles, true);
        while !translucent.is_empty() {
            let round = self.draw_translucent(scene, view, &translucent, Pass::Item, Load::Clear)?;
            drawn_triangles += if std::mem::take(&mut first) { round.triangles } else { 0 };
            let found = self.read_items()?;
            if found.is_empty() {
                break;
            }
            translucent_triangles += found.len() as u64;
            let mut nodes: Vec<NodeId> = found.iter().map(|i| i[0] - 1).collect();
            nodes.dedup();
            leaves.extend(nodes.iter().map(|&id| scene.node(id).parent));
            translucent.retain(|id| nodes.binary_search(id).is_err());
        }
        leaves.sort_unstable();
        leaves.dedup();
        // The see-through rounds listed their own nodes in the use table: the item pass's again
        // for the draws of its triangles below (gathered as then, copied from the first time).
        if !first {
            self.gather(scene, view, &ids, ClusterTests::NONE, true, None)?;
        }
        // The floors need the pass's triangles numbered as one draw numbered them.
        let (mut cluster_triangles, mut visible_draw_ms, mut cluster_draw_ms) = (None, None, None);
        if drawn.draws == 1 {
            if let Some(clusters) = visible_clusters(scene, &ids, &items)? {
                cluster_triangles = Some(clusters.iter().map(|c| c.len() as u64).sum());
                cluster_draw_ms = Some(self.draw_of_item_pass(view, &pass, clusters.into_iter().flatten())?);
            }
            visible_draw_ms = Some(self.draw_of_item_pass(view, &pass, items.iter().map(|i| i[1]))?);
        }
        Ok(ExactFrame {
            leaves,
            triangles: items.len() as u64 + translucent_triangles,
            cluster_triangles,
            drawn_triangles,
            visible_draw_ms,
            cluster_draw_ms,
            pixels,
        })
    }

    /// The distinct [node id + 1, triangle index] pairs left in the item buffer, sorted.
    fn read_items(&self) -> Result<Vec<[u32; 2]>, RenderError> {
        Ok(distinct(self.target.read_item(&self.gpu)?))
    }

    /// Draws in colour the triangles of the item pass (its indices `pass`) that `triangles`
    /// (ascending) name, in the pass's order, so that depth ties resolve as they did; returns
    /// the milliseconds from submit to done (the use table is still the item pass's: nothing
    /// was gathered since). When they hold every visible triangle, every
    /// pixel keeps the triangle that won it: the image is the item pass's.
    fn draw_of_item_pass(&mut self, view: &View, pass: &[u32], triangles: impl Iterator<Item = u32>) -> Result<f64, RenderError> {
        self.indices.clear();
        self.indices.extend(triangles.flat_map(|t| &pass[t as usize * 3..t as usize * 3 + 3]));
        let start = std::time::Instant::now();
        self.submit(view, Pass::Color, Layer::Opaque, Load::Clear, &mut Default::default())?;
        // Done, also when the renderer keeps a draw in flight (`RenderOptions::overlap`).
        self.gpu.wait()?;
        Ok(start.elapsed().as_secs_f64() * 1e3)
    }
}

/// The distinct [node id + 1, triangle index] pairs of an item buffer, sorted, less the empty
/// pixels.
fn distinct(mut items: Vec<[u32; 2]>) -> Vec<[u32; 2]> {
    items.retain(|i| i[0] != 0);
    items.sort_unstable();
    items.dedup();
    items
}

/// The triangles, numbered as in the one draw of `ids` (which drew each block's occluding
/// clusters whole and in order), of the clusters holding the visible `items` (sorted
/// [node id + 1, triangle index]), in that order; `None` if an index falls outside its node's
/// triangles.
fn visible_clusters(scene: &SceneFile, ids: &[NodeId], items: &[[u32; 2]]) -> Result<Option<Vec<Range<u32>>>, RenderError> {
    let mut clusters = Vec::new();
    let mut first = 0u64;
    let mut at = 0;
    for &id in ids {
        let g = scene.geometry(id)?;
        let end = first + g.occluder_indices() as u64 / 3;
        let mut last = None;
        while at < items.len() && items[at][0] == id + 1 {
            let t = items[at][1] as u64;
            if t < first || t >= end {
                return Ok(None);
            }
            let Some(k) = g.clusters.partition_point(|c| (c.first_index / 3) as u64 <= t - first).checked_sub(1) else {
                return Ok(None);
            };
            if last != Some(k) {
                let c = &g.clusters[k];
                let start = (first + c.first_index as u64 / 3) as u32;
                clusters.push(start..start + c.index_count / 3);
                last = Some(k);
            }
            at += 1;
        }
        first = end;
    }
    Ok((at == items.len()).then_some(clusters))
}
