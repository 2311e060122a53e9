//! A pass's index list: the opaque or translucent clusters of its nodes, read from the mapped
//! scene and offset to each node's slot in the pass's use table ([`crate::uses`]), less what
//! the cluster and triangle tests drop (osw_cull::cluster), the opaque ones copied where the
//! process tested them under the same camera already (osw_cull::gathered). The tests run on a
//! node's geometry as placed in the scene (an instance's placed on the CPU at each read); the
//! GPU draws its mesh as stored, placed by the use table. Drawing is this step and
//! [`Renderer::submit`]; OR and RVG, which take only the clusters HC's notes take
//! (osw_render::pass), call the two themselves.

use crate::draw::{Layer, Load, Pass};
use crate::renderer::{DrawStats, RenderError, Renderer};
use crate::residency::ResidencyError;
use osw_cull::View;
use osw_cull::cluster::{ClusterTests, Out, gather};
use osw_scene::block::Indices;
use osw_scene::{NodeId, SceneFile};

/// Which clusters of a node a pass takes (node, cluster index), of those past the tests.
pub type Select<'a> = dyn FnMut(NodeId, usize) -> bool + 'a;

impl Renderer {
    /// Draws LOD nodes `ids` (in the given order) for `view`, on the pass's attachments as
    /// `load` leaves them.
    ///
    /// One draw call: the nodes' indices, read from the mapped file and offset to their
    /// vertices in the arena, are gathered in the given order (so triangles rasterise in the
    /// same order as one draw per node would, and depth ties resolve alike), less the clusters
    /// that the frustum and cone tests skip (none in the item pass). Colour passes then blend
    /// the nodes' translucent clusters over it ([`Renderer::draw_translucent`]); the depth and
    /// item passes draw only the opaque ones.
    pub fn draw(&mut self, scene: &SceneFile, view: &View, ids: &[NodeId], pass: Pass, load: Load) -> Result<DrawStats, RenderError> {
        let opaque = self.draw_opaque(scene, view, ids, pass, load)?;
        match pass {
            Pass::Color | Pass::Tinted(_) | Pass::ColorOver => Ok(opaque + self.draw_translucent(scene, view, ids, pass, Load::Keep)?),
            Pass::Depth | Pass::Item => Ok(opaque),
        }
    }

    /// [`Renderer::draw`]'s first half: the opaque clusters of `ids` only, in any pass. OR and
    /// HC draw their occluders into the depth buffer with it. The depth and item passes leave
    /// out the cut-outs (`osw_scene::mesh::CUT_OUT`): what they hide is not known to be hidden.
    pub fn draw_opaque(
        &mut self,
        scene: &SceneFile,
        view: &View,
        ids: &[NodeId],
        pass: Pass,
        load: Load,
    ) -> Result<DrawStats, RenderError> {
        let tests = if pass == Pass::Item { ClusterTests::NONE } else { self.options().cluster_tests };
        let occluders_only = matches!(pass, Pass::Depth | Pass::Item);
        let drawn = self.gather(scene, view, ids, tests, occluders_only, None).and_then(|mut stats| {
            self.submit(view, pass, Layer::Opaque, load, &mut stats)?;
            Ok(stats)
        });
        match drawn {
            // More geometry than the largest GPU buffer holds (a frame at full detail of a
            // billion triangles): the list in halves, each drawn and submitted in turn.
            Err(RenderError::Residency(ResidencyError::TooLarge(_)) | RenderError::TooManyTriangles(..) | RenderError::TooManyNodes(_))
                if ids.len() > 1 =>
            {
                let (mut a, mut b) = ids.split_at(ids.len() / 2);
                if pass == Pass::ColorOver {
                    // Submitted last to first, as each half's triangles are.
                    (a, b) = (b, a);
                }
                // Nothing of the failed attempt was submitted, and everything submitted before
                // it precedes any upload on the queue: all of it may make room now.
                self.residency.next_epoch();
                let first = self.draw_opaque(scene, view, a, pass, load)?;
                self.residency.next_epoch();
                let second = self.draw_opaque(scene, view, b, pass, Load::Keep)?;
                Ok(first + second)
            }
            r => r,
        }
    }

    /// The translucent clusters of `ids` over what is drawn: depth tested against it, never
    /// written, blended in a colour pass. The nodes go far to near by their box centres, ties
    /// by id, so that every mode blends the surfaces it shares with another in the same order
    /// (a node one mode culls is hidden, and blends nothing in the other). [`Load::Clear`]
    /// clears the colour (or item ids) only, keeping the depth. The item pass takes the
    /// cut-outs too: like translucent surfaces, they are seen where they pass the depth test
    /// and hide nothing.
    pub fn draw_translucent(
        &mut self,
        scene: &SceneFile,
        view: &View,
        ids: &[NodeId],
        pass: Pass,
        load: Load,
    ) -> Result<DrawStats, RenderError> {
        let mut order: Vec<(f32, NodeId)> = ids
            .iter()
            .filter(|&&id| if pass == Pass::Item { scene.has_see_through(id) } else { scene.has_translucent(id) })
            .map(|&id| (view.relative(scene.node(id).aabb().center()).length_squared(), id))
            .collect();
        if order.is_empty() && load == Load::Keep {
            return Ok(DrawStats::default());
        }
        order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let ids: Vec<NodeId> = order.into_iter().map(|(_, id)| id).collect();
        let tests = if pass == Pass::Item { ClusterTests::NONE } else { ClusterTests { occlusion: false, ..self.options().cluster_tests } };
        // `gathered` counts nodes and clusters, `drawn` the draws.
        let (mut gathered, mut drawn, mut load) = (DrawStats::default(), DrawStats::default(), load);
        self.indices.clear();
        self.uses.begin(scene, &ids);
        for &id in &ids {
            let arena = self.arena_base(scene, id)?;
            let base = match self.uses.push(scene, view, id, arena) {
                Ok(base) => base,
                Err(_) => {
                    drawn = drawn + self.submitted(view, pass, std::mem::replace(&mut load, Load::Keep))?;
                    self.indices.clear();
                    self.uses.list.clear();
                    self.uses.push(scene, view, id, arena)?
                }
            };
            let g = scene.geometry(id)?;
            let from = if pass == Pass::Item { g.occluders } else { g.opaque };
            let (clusters, cuts) = (&g.clusters[from..], g.cuts.get(from..).unwrap_or(&[]));
            let out = &mut Out { indices: &mut self.indices, base, stats: &mut gathered.clusters };
            match &g.indices {
                Indices::U16(ix) => gather(view, tests, &g.positions, ix, clusters, cuts, out),
                Indices::U32(ix) => gather(view, tests, &g.positions, ix, clusters, cuts, out),
            }
            gathered.nodes += 1;
        }
        drawn = drawn + self.submitted(view, pass, load)?;
        Ok(DrawStats { nodes: gathered.nodes, clusters: gathered.clusters, ..drawn })
    }

    /// [`Renderer::submit`] of the translucent layer gathered so far: its draw's counts.
    fn submitted(&mut self, view: &View, pass: Pass, load: Load) -> Result<DrawStats, RenderError> {
        let mut drawn = DrawStats::default();
        self.submit(view, pass, Layer::Translucent, load, &mut drawn)?;
        Ok(drawn)
    }

    /// The first vertex in the arena of LOD node `id`'s mesh, uploaded if it is not resident.
    fn arena_base(&mut self, scene: &SceneFile, id: NodeId) -> Result<u32, RenderError> {
        let block = scene.block_at(id);
        match self.residency.resident(id, block) {
            Some(base) => Ok(base),
            None => Ok(self.residency.upload(&self.gpu, id, block, &scene.stored_geometry(id)?)?),
        }
    }

    /// Gathers into `self.indices` the indices of the opaque clusters of `ids` (with
    /// `occluders_only`, less the cut-outs) that pass `tests` and `select(node, cluster index)`
    /// (all when `None`), less the triangles `tests` drop, making the nodes' meshes resident and
    /// listing the nodes in `self.uses`; returns their counts. What was tested under this view
    /// and tests is copied ([`osw_cull::gathered::Gathered`]).
    pub fn gather(
        &mut self,
        scene: &SceneFile,
        view: &View,
        ids: &[NodeId],
        tests: ClusterTests,
        occluders_only: bool,
        mut select: Option<&mut Select>,
    ) -> Result<DrawStats, RenderError> {
        debug_assert_eq!(scene.nodes().len(), self.nodes, "a renderer serves the scene it was made for");
        let mut stats = DrawStats::default();
        self.indices.clear();
        self.uses.begin(scene, ids);
        for &id in ids {
            stats.nodes += 1;
            let arena = self.arena_base(scene, id)?;
            let base = self.uses.push(scene, view, id, arena)?;
            let end = if occluders_only { scene.occluder_clusters(id) as usize } else { usize::MAX };
            let mut below = move |k: usize| k < end;
            let select: &mut dyn FnMut(usize) -> bool = match select.as_deref_mut() {
                Some(select) => &mut move |k| k < end && select(id, k),
                None => &mut below,
            };
            // An instance's geometry is placed at each read: read only when needed.
            let out = &mut Out { indices: &mut self.indices, base, stats: &mut stats.clusters };
            self.gathered.gather(view, tests, id, || scene.geometry(id), select, out)?;
        }
        stats.triangles = self.indices.len() as u64 / 3;
        Ok(stats)
    }
}
