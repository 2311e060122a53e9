//! One scene, one image size, one device: draw, test boxes, exact visibility, read frames.
//! Every operation submits its work and waits, so the CPU timings around it are GPU times on
//! lavapipe (which runs on the CPU anyway).

use crate::boxtest::{BoxTestPipelines, GpuBox};
use crate::device::{Gpu, GpuError};
use crate::draw::{DrawPipelines, Layer, Pass, ViewUniform};
use crate::pyramid::Pyramid;
use crate::residency::{Residency, ResidencyError};
use crate::target::Target;
use osw_cull::cluster::{ClusterHistory, ClusterStats, ClusterTests, gather};
use osw_cull::gathered::Gathered;
use osw_cull::{Occluders, View, Visibility, VisibilityTester};
use osw_scene::file::Indices;
use osw_scene::format::ClusterRecord;
use osw_scene::{NodeId, SceneError, SceneFile};
use std::sync::Arc;

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Residency(#[from] ResidencyError),
    #[error("image size {0}x{1} is out of range (1..={max} a side)", max = crate::limits::MAX_SIZE)]
    Size(u32, u32),
    #[error("{0} triangles in one pass, more than the largest GPU buffer holds ({1} bytes)")]
    TooManyTriangles(u64, u64),
}

/// How the GPU tests boxes against the occluders (measured: docs/measurements/2026-12-01-scene-and-renderer.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoxTest {
    /// Rasterised boxes against the depth buffer, exact per pixel (forced early depth).
    Exact,
    /// As `Exact`, counting each box's visible pixels (occlusion switch sec. 4.7.2).
    ExactCount,
    /// The farthest-depth pyramid in a compute pass: conservative, no pixel counts.
    Pyramid,
    /// One occlusion query per box (occlusion switch sec. 4.7.1: GL_NV_occlusion_query), the
    /// paper-faithful reference. wgpu documents only zero / non-zero results.
    Queries,
}

/// Background of colour frames: a pale sky, so that what is open to the outside reads as such.
const SKY: wgpu::Color = wgpu::Color { r: 0.62, g: 0.74, b: 0.86, a: 1.0 };

/// Most occlusion queries in one query set (wgpu's limit).
const QUERIES: u32 = 4096;

/// Counts of one draw call list.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DrawStats {
    pub nodes: u32,
    pub triangles: u64,
    pub clusters: ClusterStats,
    /// Draw calls submitted (more than one when a list outgrew the GPU's buffers).
    pub draws: u32,
    /// Fragment shader invocations of the draws (lavapipe: the pixels covered, in whole 2x2
    /// quads, before the depth test), when counted ([`Renderer::count_fragments`]).
    pub fragments: u64,
    /// GPU time of the draws' render passes, ns, from timestamps ([`Renderer::time_gpu`]).
    pub gpu_ns: Option<u64>,
}

/// Both draws' counts and times.
impl std::ops::Add for DrawStats {
    type Output = DrawStats;

    fn add(self, o: DrawStats) -> DrawStats {
        DrawStats {
            nodes: self.nodes + o.nodes,
            triangles: self.triangles + o.triangles,
            draws: self.draws + o.draws,
            clusters: self.clusters + o.clusters,
            fragments: self.fragments + o.fragments,
            gpu_ns: match (self.gpu_ns, o.gpu_ns) {
                (Some(a), Some(b)) => Some(a + b),
                (a, b) => a.or(b),
            },
        }
    }
}

impl DrawStats {
    /// The draws' GPU time in ms, where timed.
    pub fn gpu_ms(&self) -> Option<f64> {
        self.gpu_ns.map(|ns| ns as f64 / 1e6)
    }
}

pub struct Renderer {
    pub gpu: Gpu,
    pub scene: Arc<SceneFile>,
    pub target: Target,
    pub residency: Residency,
    /// The cluster tests of colour and depth passes (the item pass, exact visibility's
    /// reference, draws every triangle).
    pub cluster_tests: ClusterTests,
    /// Exact box tests read one pixel line in `.0`, from line `.1` (Bartz 1999 sec. 3.3's
    /// interleaved sampling, see shaders/boxtest.wgsl); (1, 0) reads every line.
    pub sampling: (u32, u32),
    /// Count each draw's fragments ([`DrawStats::fragments`]): a pipeline-statistics query
    /// and a read-back per draw, so off unless asked for. Without the adapter's feature the
    /// count stays 0 ([`Renderer::counts_fragments`]).
    pub count_fragments: bool,
    /// Time each draw's render pass on the GPU ([`DrawStats::gpu_ns`]): two timestamps and a
    /// read-back per draw, which waits for it (also with `overlap`), so off unless asked
    /// for. Without the adapter's feature there is no time ([`Renderer::times_gpu`]).
    pub time_gpu: bool,
    /// A draw returns once it is submitted and the draw before it is done, not once it is
    /// drawn: one draw in flight, so that the CPU gathers the next frame while the GPU draws
    /// this one (the display). Read-backs still wait for everything before them.
    pub overlap: bool,
    draw: DrawPipelines,
    boxtest: BoxTestPipelines,
    pyramid: Pyramid,
    view_buf: wgpu::Buffer,
    draw_group: wgpu::BindGroup,
    /// The pass's indices into the vertex arena, gathered from the nodes' (see `draw`).
    index_buf: wgpu::Buffer,
    boxes_buf: wgpu::Buffer,
    results_buf: wgpu::Buffer,
    results_staging: wgpu::Buffer,
    box_group: wgpu::BindGroup,
    queries: wgpu::QuerySet,
    query_resolve: wgpu::Buffer,
    query_staging: wgpu::Buffer,
    /// The fragment count's query, resolve and read-back buffers (with the adapter's feature).
    fragment_query: Option<(wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer)>,
    /// The same for a pass's two timestamps.
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer)>,
    pub(crate) indices: Vec<u32>,
    /// Each node's indices as last gathered, for passes of the same view.
    gathered: Gathered,
    gpu_boxes: Vec<GpuBox>,
}

fn storage(gpu: &Gpu, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
}

/// Which clusters of a node a pass takes (node, cluster index, cluster), after the tests.
type Select<'a> = dyn FnMut(NodeId, usize, &ClusterRecord) -> bool + 'a;

/// One node's part of [`Renderer::gather`]: every cluster that passes `tests` through the
/// indices kept for this view, or those that `select` takes.
#[allow(clippy::too_many_arguments)]
fn gather_node<I: Copy + Into<u32>>(
    view: &View,
    tests: ClusterTests,
    id: NodeId,
    geometry: (&[[f32; 3]], &[I], &[ClusterRecord]),
    select: Option<&mut Select>,
    gathered: &mut Gathered,
    base: u32,
    stats: &mut ClusterStats,
    out: &mut Vec<u32>,
) {
    match select {
        None => gathered.gather(view, tests, (id, base), geometry, stats, out),
        Some(select) => gather(view, tests, geometry, stats, |k, c| select(id, k, c), base, out),
    }
}

/// RVG's cluster occlusion test reads the pyramid this many levels finer than Peng 2014's 2x2
/// texels: a box spans at most 64 texels a side. On the 5M plant walk at tau 5, 2 levels left
/// 10,246 of 13,451 triangles a frame, 5 levels 8,960 (docs/measurements/2026-12-02-clusters.md).
const CLUSTER_FINER: u32 = 5;

impl Renderer {
    pub fn new(gpu: Gpu, scene: Arc<SceneFile>, width: u32, height: u32, residency_bytes: u64) -> Result<Renderer, RenderError> {
        let max = crate::limits::MAX_SIZE;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::Size(width, height));
        }
        use wgpu::BufferUsages as U;
        let draw = DrawPipelines::new(&gpu.device);
        let boxtest = BoxTestPipelines::new(&gpu.device);
        let view_buf = storage(&gpu, "view", std::mem::size_of::<ViewUniform>() as u64, U::UNIFORM | U::COPY_DST);
        // Each node's object, for its colour: static, indexed by node id.
        let objects: Vec<u32> = scene.nodes().iter().map(|n| n.object).collect();
        let objects_buf = storage(&gpu, "objects", (objects.len().max(1) * 4) as u64, U::STORAGE | U::COPY_DST);
        gpu.queue.write_buffer(&objects_buf, 0, bytemuck::cast_slice(&objects));
        let index_buf = storage(&gpu, "pass indices", 4, U::INDEX | U::COPY_DST);
        let n = crate::limits::MAX_BOXES as u64;
        let boxes_buf = storage(&gpu, "boxes", n * 32, U::STORAGE | U::COPY_DST);
        let results_buf = storage(&gpu, "box results", n * 4, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        let results_staging = crate::readback::staging(&gpu, "box results readback", n * 4);
        let bind = |layout: &wgpu::BindGroupLayout, bufs: &[&wgpu::Buffer]| {
            let entries: Vec<wgpu::BindGroupEntry> =
                bufs.iter().enumerate().map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() }).collect();
            gpu.device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout, entries: &entries })
        };
        let draw_group = bind(&draw.layout, &[&view_buf, &objects_buf]);
        let box_group = bind(&boxtest.layout, &[&view_buf, &boxes_buf, &results_buf]);
        let target = Target::new(&gpu, width, height);
        let pyramid = Pyramid::new(&gpu, &target, &view_buf, &boxes_buf, &results_buf);
        let queries = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("box queries"),
            ty: wgpu::QueryType::Occlusion,
            count: QUERIES,
        });
        let query_resolve = storage(&gpu, "query resolve", QUERIES as u64 * 8, U::QUERY_RESOLVE | U::COPY_SRC);
        let query_staging = crate::readback::staging(&gpu, "query readback", QUERIES as u64 * 8);
        let fragment_query = gpu.features.contains(wgpu::Features::PIPELINE_STATISTICS_QUERY).then(|| {
            let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("fragments"),
                ty: wgpu::QueryType::PipelineStatistics(wgpu::PipelineStatisticsTypes::FRAGMENT_SHADER_INVOCATIONS),
                count: 1,
            });
            (
                set,
                storage(&gpu, "fragments resolve", 8, U::QUERY_RESOLVE | U::COPY_SRC),
                crate::readback::staging(&gpu, "fragments readback", 8),
            )
        });
        let timestamps = gpu.features.contains(wgpu::Features::TIMESTAMP_QUERY).then(|| {
            let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass times"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            (
                set,
                storage(&gpu, "pass times resolve", 16, U::QUERY_RESOLVE | U::COPY_SRC),
                crate::readback::staging(&gpu, "pass times readback", 16),
            )
        });
        Ok(Renderer {
            fragment_query,
            timestamps,
            time_gpu: false,
            count_fragments: false,
            overlap: false,
            queries,
            query_resolve,
            query_staging,
            pyramid,
            target,
            residency: Residency::new(residency_bytes),
            cluster_tests: ClusterTests::default(),
            sampling: (1, 0),
            draw,
            boxtest,
            view_buf,
            draw_group,
            index_buf,
            boxes_buf,
            results_buf,
            results_staging,
            box_group,
            indices: Vec::new(),
            gathered: Gathered::default(),
            gpu_boxes: Vec::new(),
            gpu,
            scene,
        })
    }

    /// Whether draws count their fragments: asked for, and the adapter can.
    pub fn counts_fragments(&self) -> bool {
        self.count_fragments && self.fragment_query.is_some()
    }

    /// Whether draws are timed on the GPU: asked for, and the adapter has timestamps.
    pub fn times_gpu(&self) -> bool {
        self.time_gpu && self.timestamps.is_some()
    }

    /// The view of `camera` with this scene's near plane (see [`osw_cull::view::near_of`]).
    pub fn view(&self, camera: &osw_scene::Camera) -> View {
        View::new(camera, self.scene.origin(), self.target.width, self.target.height, osw_cull::view::near_of(&self.scene))
    }

    /// Starts a frame: geometry used from here on is kept resident through the frame.
    pub fn begin_frame(&mut self) {
        self.residency.next_epoch();
    }

    /// Draws LOD nodes `ids` (in the given order) for `view`. `clear` clears the pass's
    /// attachments first (colour to the sky, item ids to 0, depth to 0 = infinitely far), else draws on top.
    ///
    /// One draw call: the nodes' indices, read from the mapped file and offset to their
    /// vertices in the arena, are gathered in the given order (so triangles rasterise in the
    /// same order as one draw per node would, and depth ties resolve alike), less the clusters
    /// that the frustum and cone tests skip (none in the item pass). Colour passes then blend
    /// the nodes' translucent clusters over it ([`Renderer::draw_translucent`]); the depth and
    /// item passes draw only the opaque ones.
    pub fn draw(&mut self, view: &View, ids: &[NodeId], pass: Pass, clear: bool) -> Result<DrawStats, RenderError> {
        let opaque = self.draw_opaque(view, ids, pass, clear)?;
        match pass {
            Pass::Color | Pass::Tinted(_) => Ok(opaque + self.draw_translucent(view, ids, pass, false)?),
            Pass::Depth | Pass::Item => Ok(opaque),
        }
    }

    fn draw_opaque(&mut self, view: &View, ids: &[NodeId], pass: Pass, clear: bool) -> Result<DrawStats, RenderError> {
        let tests = if pass == Pass::Item { ClusterTests::NONE } else { self.cluster_tests };
        let drawn = self.gather(view, ids, tests, None).and_then(|mut stats| {
            self.submit(view, pass, Layer::Opaque, clear, &mut stats)?;
            Ok(stats)
        });
        match drawn {
            // More geometry than the largest GPU buffer holds (a frame at full detail of a
            // billion triangles): the list in halves, each drawn and submitted in turn.
            Err(RenderError::Residency(ResidencyError::TooLarge(_)) | RenderError::TooManyTriangles(..)) if ids.len() > 1 => {
                let (a, b) = ids.split_at(ids.len() / 2);
                // Nothing of the failed attempt was submitted, and everything submitted before
                // it precedes any upload on the queue: all of it may make room now.
                self.residency.next_epoch();
                let first = self.draw_opaque(view, a, pass, clear)?;
                self.residency.next_epoch();
                let second = self.draw_opaque(view, b, pass, false)?;
                Ok(first + second)
            }
            r => r,
        }
    }

    /// The translucent clusters of `ids` over what is drawn: depth tested against it, never
    /// written, blended in a colour pass. The nodes go far to near by their box centres, ties
    /// by id, so that every mode blends the surfaces it shares with another in the same order
    /// (a node one mode culls is hidden, and blends nothing in the other). `clear` clears the
    /// colour (or item ids) only, keeping the depth.
    pub fn draw_translucent(&mut self, view: &View, ids: &[NodeId], pass: Pass, clear: bool) -> Result<DrawStats, RenderError> {
        let scene = Arc::clone(&self.scene);
        let mut order: Vec<(f32, NodeId)> = ids
            .iter()
            .filter(|&&id| scene.has_translucent(id))
            .map(|&id| (view.relative(scene.node(id).aabb().center()).length_squared(), id))
            .collect();
        let mut stats = DrawStats::default();
        if order.is_empty() && !clear {
            return Ok(stats);
        }
        order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let tests = if pass == Pass::Item { ClusterTests::NONE } else { ClusterTests { occlusion: false, ..self.cluster_tests } };
        self.indices.clear();
        for (_, id) in order {
            let base = self.residency.ensure(&self.gpu, &scene, id)?;
            let g = scene.geometry(id)?;
            let (out, s, clusters) = (&mut self.indices, &mut stats.clusters, &g.clusters[g.opaque..]);
            match g.indices {
                Indices::U16(ix) => gather(view, tests, (g.positions, ix, clusters), s, |_, _| true, base, out),
                Indices::U32(ix) => gather(view, tests, (g.positions, ix, clusters), s, |_, _| true, base, out),
            }
            stats.nodes += 1;
        }
        self.submit(view, pass, Layer::Translucent, clear, &mut stats)?;
        Ok(stats)
    }

    /// RVG's draw of the visible set with occlusion culling of clusters, in two passes as in
    /// niagara: first the clusters of `ids` that `history` says were visible in the last frame,
    /// then every cluster's box is tested against the farthest-depth pyramid of what that drew
    /// (read back; on lavapipe the exact GPU box test per cluster took RVG from 43 to 63 ms,
    /// this one breaks even: docs/measurements/2026-12-02-clusters.md), and those visible and not yet drawn
    /// are drawn. Conservative: a cluster is skipped only when geometry drawn this frame hides
    /// all of its box. `history` then holds this frame's visible clusters. Without the
    /// occlusion test, [`Renderer::draw`].
    pub fn draw_visible(
        &mut self,
        view: &View,
        ids: &[NodeId],
        pass: Pass,
        history: &mut ClusterHistory,
    ) -> Result<DrawStats, RenderError> {
        let tests = self.cluster_tests;
        if !tests.occlusion {
            return self.draw(view, ids, pass, true);
        }
        let mut first = self.gather(view, ids, tests, Some(&mut |id, k, _| history.was_visible(id, k)))?;
        self.submit(view, pass, Layer::Opaque, true, &mut first)?;
        // Every cluster that passes the frustum and cone tests, its box tested against the
        // farthest-depth pyramid of what the first pass drew (boxes around the eye or across
        // the near plane count as visible, as in HC); the second pass draws those visible
        // now and not drawn in the first.
        let pyramid = osw_cull::hzb::Pyramid::new(view.width, view.height, self.target.read_depth(&self.gpu)?);
        let vp = view.view_proj().as_dmat4();
        let mut occluded = 0;
        let mut stats = self.gather(
            view,
            ids,
            tests,
            Some(&mut |id, k, c: &ClusterRecord| {
                let b = c.aabb();
                let drawn = history.was_visible(id, k);
                if view.frustum.needs_no_test(&b) || osw_cull::hzb::visible_box(&pyramid, &vp, view, &b, CLUSTER_FINER) {
                    history.mark(id, k);
                    return !drawn;
                }
                occluded += u64::from(!drawn);
                false
            }),
        )?;
        self.submit(view, pass, Layer::Opaque, false, &mut stats)?;
        history.end_frame();
        stats.triangles += first.triangles;
        stats.fragments += first.fragments;
        stats.clusters.occlusion_culled = occluded;
        // The triangle tests ran on what the two passes drew.
        stats.clusters.backface_culled += first.clusters.backface_culled;
        stats.clusters.small_culled += first.clusters.small_culled;
        Ok(stats + self.draw_translucent(view, ids, pass, false)?)
    }

    /// Gathers into `self.indices` the indices of the opaque clusters of `ids` that pass `tests`
    /// and `select(node, cluster index, cluster)` (all, through the indices kept for this view,
    /// when `None`), less the triangles `tests` drop, making the nodes resident.
    fn gather(
        &mut self,
        view: &View,
        ids: &[NodeId],
        tests: ClusterTests,
        mut select: Option<&mut Select>,
    ) -> Result<DrawStats, RenderError> {
        let scene = Arc::clone(&self.scene);
        let mut stats = DrawStats::default();
        self.indices.clear();
        for &id in ids {
            let base = self.residency.ensure(&self.gpu, &scene, id)?;
            let g = scene.geometry(id)?;
            let (out, s, gathered) = (&mut self.indices, &mut stats.clusters, &mut self.gathered);
            let (select, clusters) = (select.as_deref_mut(), &g.clusters[..g.opaque]);
            match g.indices {
                Indices::U16(ix) => gather_node(view, tests, id, (g.positions, ix, clusters), select, gathered, base, s, out),
                Indices::U32(ix) => gather_node(view, tests, id, (g.positions, ix, clusters), select, gathered, base, s, out),
            }
            stats.nodes += 1;
        }
        Ok(stats)
    }

    /// Draws the gathered indices in one call; counts them into `stats.triangles`, and their
    /// fragments into `stats.fragments` when [`Renderer::counts_fragments`]. A translucent
    /// layer keeps the depth when it clears.
    pub(crate) fn submit(&mut self, view: &View, pass: Pass, layer: Layer, clear: bool, stats: &mut DrawStats) -> Result<(), RenderError> {
        // What is submitted, not what the node table says.
        stats.triangles = self.indices.len() as u64 / 3;
        stats.draws = 1;
        let bytes = self.indices.len() as u64 * 4;
        if bytes > self.index_buf.size() {
            let max = self.gpu.device.limits().max_buffer_size;
            if bytes > max {
                return Err(RenderError::TooManyTriangles(stats.triangles, max));
            }
            let size = bytes.next_power_of_two().min(max);
            self.index_buf = storage(&self.gpu, "pass indices", size, wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST);
        }
        let q = &self.gpu.queue;
        q.write_buffer(&self.view_buf, 0, bytemuck::bytes_of(&ViewUniform { tint: [pass.tint(), 0, 0, 0], ..ViewUniform::new(view) }));
        if bytes > 0 {
            q.write_buffer(&self.index_buf, 0, bytemuck::cast_slice(&self.indices));
        }
        let mut enc = self.gpu.device.create_command_encoder(&Default::default());
        let query = self.fragment_query.as_ref().filter(|_| self.count_fragments);
        let times = self.timestamps.as_ref().filter(|_| self.time_gpu);
        {
            let load = |c| if clear { wgpu::LoadOp::Clear(c) } else { wgpu::LoadOp::Load };
            let color_view = match pass {
                Pass::Color | Pass::Tinted(_) => Some(&self.target.color),
                Pass::Item => Some(&self.target.item),
                Pass::Depth => None,
            };
            let color = color_view.map(|v| wgpu::RenderPassColorAttachment {
                view: v,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: load(if pass == Pass::Item { wgpu::Color::BLACK } else { SKY }),
                    store: wgpu::StoreOp::Store,
                },
            });
            let colors = [color];
            let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("draw"),
                // The depth-only pass has no colour attachment at all (not an empty slot).
                color_attachments: if colors[0].is_some() { &colors } else { &[] },
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.target.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: if clear && layer == Layer::Opaque { wgpu::LoadOp::Clear(0.0) } else { wgpu::LoadOp::Load },
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: times.map(|(set, _, _)| wgpu::RenderPassTimestampWrites {
                    query_set: set,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if let Some((set, _, _)) = query {
                rp.begin_pipeline_statistics_query(set, 0);
            }
            if let (Some(arena), true) = (self.residency.arena(), bytes > 0) {
                rp.set_pipeline(self.draw.pipeline(pass, layer));
                rp.set_bind_group(0, &self.draw_group, &[]);
                rp.set_vertex_buffer(0, arena.slice(..));
                rp.set_index_buffer(self.index_buf.slice(..bytes), wgpu::IndexFormat::Uint32);
                rp.draw_indexed(0..self.indices.len() as u32, 0, 0..1);
            }
            if query.is_some() {
                rp.end_pipeline_statistics_query();
            }
        }
        if let Some((set, resolve, staging)) = query {
            enc.resolve_query_set(set, 0..1, resolve, 0);
            enc.copy_buffer_to_buffer(resolve, 0, staging, 0, Some(8));
        }
        if let Some((set, resolve, staging)) = times {
            enc.resolve_query_set(set, 0..2, resolve, 0);
            enc.copy_buffer_to_buffer(resolve, 0, staging, 0, Some(16));
        }
        if self.overlap {
            self.gpu.wait()?;
        }
        self.gpu.queue.submit([enc.finish()]);
        match query {
            Some((_, _, staging)) => stats.fragments = crate::readback::read(&self.gpu, staging, 8, bytemuck::pod_read_unaligned::<u64>)?,
            None if !self.overlap => self.gpu.wait()?,
            None => {}
        }
        if let Some((_, _, staging)) = times {
            let [start, end] = crate::readback::read(&self.gpu, staging, 16, bytemuck::pod_read_unaligned::<[u64; 2]>)?;
            let ns = (end.saturating_sub(start) as f64 * self.gpu.queue.get_timestamp_period() as f64) as u64;
            stats.gpu_ns = Some(stats.gpu_ns.unwrap_or(0) + ns);
        }
        self.residency.trim();
        Ok(())
    }

    /// Records the farthest-depth pyramid of the depth buffer as it is now, for
    /// [`BoxTest::Pyramid`] (after the occluders are drawn, before the boxes are tested).
    pub fn build_pyramid(&mut self) {
        let mut enc = self.gpu.device.create_command_encoder(&Default::default());
        self.pyramid.encode_build(&self.target, &mut enc);
        self.gpu.queue.submit([enc.finish()]);
    }

    /// Tests the boxes of BVH nodes `ids` against the occluders: the depth buffer as it is now
    /// (exact tests) or the pyramid last built from it. Appends one answer per id.
    pub fn test_boxes(&mut self, view: &View, ids: &[NodeId], test: BoxTest, out: &mut Vec<Visibility>) -> Result<(), RenderError> {
        let mut words = Vec::with_capacity(ids.len());
        let scene = Arc::clone(&self.scene);
        self.test_raw(view, &mut ids.iter().map(|&id| scene.node(id).aabb()), test, &mut words)?;
        let counts = test == BoxTest::ExactCount;
        out.extend(words.iter().map(|&w| Visibility { visible: w > 0, pixels: counts.then_some(w) }));
        Ok(())
    }

    /// The raw answer per box: exact flag or pixel count, query non-zero, or for the pyramid
    /// 0 (hidden) or 1 + the level read (u32::MAX: a corner behind the eye).
    fn test_raw(
        &mut self,
        view: &View,
        boxes: &mut dyn Iterator<Item = osw_scene::Aabb>,
        test: BoxTest,
        out: &mut Vec<u32>,
    ) -> Result<(), RenderError> {
        self.gpu.queue.write_buffer(&self.view_buf, 0, bytemuck::bytes_of(&ViewUniform::new(view)));
        let chunk_len = if test == BoxTest::Queries { QUERIES } else { crate::limits::MAX_BOXES };
        loop {
            self.gpu_boxes.clear();
            for b in (&mut *boxes).take(chunk_len as usize) {
                let (lo, hi) = view.test_box(&b);
                let (lo, hi) = (lo.as_vec3(), hi.as_vec3());
                let (lines, first) = self.sampling;
                self.gpu_boxes.push(GpuBox { lo: lo.extend(lines as f32).to_array(), hi: hi.extend(first as f32).to_array() });
            }
            if self.gpu_boxes.is_empty() {
                return Ok(());
            }
            let n = self.gpu_boxes.len() as u32;
            self.gpu.queue.write_buffer(&self.boxes_buf, 0, bytemuck::cast_slice(&self.gpu_boxes));
            let mut enc = self.gpu.device.create_command_encoder(&Default::default());
            match test {
                BoxTest::Queries => {
                    let mut rp = self.box_pass(&mut enc, &self.boxtest.flag, Some(&self.queries));
                    for i in 0..n {
                        rp.begin_occlusion_query(i);
                        rp.draw(0..36, i..i + 1);
                        rp.end_occlusion_query();
                    }
                    drop(rp);
                    enc.resolve_query_set(&self.queries, 0..n, &self.query_resolve, 0);
                    enc.copy_buffer_to_buffer(&self.query_resolve, 0, &self.query_staging, 0, Some(n as u64 * 8));
                    self.gpu.queue.submit([enc.finish()]);
                    crate::readback::read(&self.gpu, &self.query_staging, n as u64 * 8, |bytes| {
                        let samples: &[u64] = bytemuck::cast_slice(bytes);
                        out.extend(samples.iter().map(|&q| (q > 0) as u32));
                    })?;
                    continue;
                }
                BoxTest::Pyramid => {
                    enc.clear_buffer(&self.results_buf, 0, Some(n as u64 * 4));
                    self.pyramid.encode_cull(&self.gpu, &mut enc, n);
                }
                BoxTest::Exact | BoxTest::ExactCount => {
                    enc.clear_buffer(&self.results_buf, 0, Some(n as u64 * 4));
                    let pipeline = if test == BoxTest::ExactCount { &self.boxtest.count } else { &self.boxtest.flag };
                    self.box_pass(&mut enc, pipeline, None).draw(0..36, 0..n);
                }
            }
            enc.copy_buffer_to_buffer(&self.results_buf, 0, &self.results_staging, 0, Some(n as u64 * 4));
            self.gpu.queue.submit([enc.finish()]);
            crate::readback::read(&self.gpu, &self.results_staging, n as u64 * 4, |bytes| {
                out.extend_from_slice(bytemuck::cast_slice(bytes))
            })?;
        }
    }

    /// A pass rasterising the boxes with `pipeline` against the depth buffer, counted by
    /// `queries` when given.
    fn box_pass<'a>(
        &'a self,
        enc: &'a mut wgpu::CommandEncoder,
        pipeline: &'a wgpu::RenderPipeline,
        queries: Option<&'a wgpu::QuerySet>,
    ) -> wgpu::RenderPass<'a> {
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("boxtest"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.target.depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: queries,
            multiview_mask: None,
        });
        rp.set_pipeline(pipeline);
        rp.set_bind_group(0, &self.box_group, &[]);
        rp
    }

    /// The colour attachment, RGBA8 rows top first.
    pub fn read_color(&self) -> Result<Vec<u8>, RenderError> {
        Ok(self.target.read_color(&self.gpu)?)
    }
}

/// A [`VisibilityTester`] on the GPU box test; a GPU error ends the traversal with it.
pub struct GpuTester<'a> {
    pub renderer: &'a mut Renderer,
    pub test: BoxTest,
}

impl VisibilityTester for GpuTester<'_> {
    type Error = RenderError;

    fn test(&mut self, view: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), RenderError> {
        self.renderer.test_boxes(view, ids, self.test, out)
    }
}

/// An [`Occluders`] tester for the interleaved traversals (S&W, CHC): nodes to draw are
/// collected and drawn depth-only into the occluder buffer right before the next test, so
/// every test sees everything drawn before it was issued, in as few submissions as possible.
pub struct InterleavedTester<'a> {
    pub tester: GpuTester<'a>,
    pending: Vec<NodeId>,
}

impl<'a> InterleavedTester<'a> {
    pub fn new(renderer: &'a mut Renderer) -> InterleavedTester<'a> {
        InterleavedTester { tester: GpuTester { renderer, test: BoxTest::Exact }, pending: Vec::new() }
    }

    /// Draws what is still pending.
    pub fn finish(mut self, view: &View) -> Result<(), RenderError> {
        self.flush(view)
    }

    fn flush(&mut self, view: &View) -> Result<(), RenderError> {
        if !self.pending.is_empty() {
            self.tester.renderer.draw(view, &self.pending, crate::draw::Pass::Depth, false)?;
        }
        self.pending.clear();
        Ok(())
    }
}

impl VisibilityTester for InterleavedTester<'_> {
    type Error = RenderError;

    fn test(&mut self, view: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), RenderError> {
        self.flush(view)?;
        self.tester.test(view, ids, out)
    }
}

impl Occluders for InterleavedTester<'_> {
    fn render(&mut self, lods: &[NodeId]) -> Result<(), RenderError> {
        self.pending.extend_from_slice(lods);
        Ok(())
    }
}
