//! One scene, one image size, one device: submit index lists, test boxes, read frames.
//! Every operation submits its work and waits, so the CPU timings around it are GPU times on
//! lavapipe (which runs on the CPU anyway).

use crate::boxtest::{BoxTestPipelines, GpuBox};
use crate::device::{Gpu, GpuError};
use crate::draw::{DrawPipelines, Layer, Load, Pass, ViewUniform};
use crate::pyramid::Pyramid;
use crate::residency::{Residency, ResidencyError, ResidencyStats};
use crate::target::Target;
use crate::uses::{Rows, Uses};
use osw_cull::cluster::{ClusterStats, ClusterTests};
use osw_cull::gathered::Gathered;
use osw_cull::{View, Visibility};
use osw_scene::{SceneError, SceneFile};

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
    #[error(transparent)]
    TooManyNodes(#[from] crate::uses::TooManyNodes),
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

impl BoxTest {
    /// The name a debugger shows for a batch of this test.
    pub fn label(self) -> &'static str {
        match self {
            BoxTest::Exact => "boxtest",
            BoxTest::ExactCount => "boxtest count",
            BoxTest::Pyramid => "boxtest pyramid",
            BoxTest::Queries => "boxtest queries",
        }
    }
}

/// Bartz 1999 sec. 3.3's interleaved sampling of exact box tests: one pixel line in `lines`
/// is read, from line `first` (see shaders/boxtest.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampling {
    pub lines: u32,
    pub first: u32,
}

impl Sampling {
    pub const EVERY_LINE: Sampling = Sampling { lines: 1, first: 0 };
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
    /// quads, before the depth test), when counted ([`RenderOptions::count_fragments`]).
    pub fragments: u64,
    /// GPU time of the draws' render passes, ns, from timestamps ([`RenderOptions::time_gpu`]).
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

/// What a renderer does besides drawing, and its limits, chosen once for its life.
#[derive(Clone, Copy, Debug)]
pub struct RenderOptions {
    /// The cluster tests of colour and depth passes (the item pass, exact visibility's
    /// reference, draws every triangle).
    pub cluster_tests: ClusterTests,
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
    /// Place instances with f32 rows ([`Rows::Single`]) also where the adapter has 64-bit
    /// floats: what an adapter without them draws.
    pub single_rows: bool,
    /// Colour passes shade with the scene's normals and textures, uploaded beside the
    /// vertices; without, every surface is shaded flat in its colour and nothing but positions
    /// and colours is uploaded (OR and HC draw no colour).
    pub shade: bool,
    /// Textured surfaces sample their textures; without, they are drawn in each texture's
    /// mean colour (the textures are uploaded all the same).
    pub textures: bool,
    /// Every texture sampled at this level of its mip chain, whatever a pixel's footprint
    /// (tests compare a level with a reference sampler).
    pub texture_level: Option<f32>,
    /// Geometry residency budget, bytes ([`crate::residency`]).
    pub residency_bytes: u64,
    /// Largest vertex arena, bytes: the device's largest buffer, or less (tests make a frame's
    /// geometry overflow it without a billion triangles).
    pub max_arena_bytes: u64,
    /// Most nodes in one draw, below what its indices can name ([`crate::uses`]): tests make
    /// a pass overflow without a billion triangles.
    pub max_nodes: usize,
}

impl Default for RenderOptions {
    fn default() -> RenderOptions {
        RenderOptions {
            cluster_tests: ClusterTests::default(),
            count_fragments: false,
            time_gpu: false,
            overlap: false,
            single_rows: false,
            shade: true,
            textures: true,
            texture_level: None,
            residency_bytes: crate::limits::RESIDENCY_BYTES,
            max_arena_bytes: u64::MAX,
            max_nodes: usize::MAX,
        }
    }
}

/// The device resources of one scene at one image size: geometry resident on the GPU, the
/// attachments, the pipelines; passes gather their index lists ([`crate::gather`]) and submit
/// them here. The scene is the caller's, passed to each call that reads it; residency keys on
/// its node ids, so a renderer serves the one scene it was made for.
pub struct Renderer {
    pub(crate) gpu: Gpu,
    pub(crate) target: Target,
    pub(crate) residency: Residency,
    options: RenderOptions,
    /// The scene's origin and near plane, for [`Renderer::view`].
    origin: glam::DVec3,
    near: f64,
    /// The scene's node count, to catch a call with another scene.
    pub(crate) nodes: usize,
    draw: DrawPipelines,
    boxtest: BoxTestPipelines,
    pyramid: Pyramid,
    view_buf: wgpu::Buffer,
    /// The pass's use table on the GPU ([`crate::uses`]).
    uses_buf: wgpu::Buffer,
    /// The draw pipelines' bind group, and the arena, use table, normal and texcoord arenas it
    /// binds.
    draw_group: Option<(wgpu::BindGroup, [wgpu::Buffer; 4])>,
    /// What the draw pipelines bind as normals and texture coordinates where none are uploaded.
    no_normals: wgpu::Buffer,
    no_texcoords: wgpu::Buffer,
    /// The scene's textures, where the renderer shades (else none).
    atlas: crate::atlas::Atlas,
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
    /// The pass's index list, as gathered ([`crate::gather`]), and the nodes its indices name.
    pub(crate) indices: Vec<u32>,
    /// The pass's draws: ranges of `indices`, and whether each holds textured triangles.
    draws: Vec<(std::ops::Range<u32>, bool)>,
    pub(crate) uses: Uses,
    /// Each node's indices as last gathered, for passes of the same view.
    pub(crate) gathered: Gathered,
    gpu_boxes: Vec<GpuBox>,
    /// The storage of the last CPU depth pyramid given back.
    spare_pyramid: Option<osw_cull::hzb::Pyramid>,
}

fn storage(gpu: &Gpu, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
}

/// A set of `count` queries of type `ty`, with its resolve and read-back buffers (8 bytes a query).
fn query_set(gpu: &Gpu, label: &str, ty: wgpu::QueryType, count: u32) -> (wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer) {
    let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor { label: Some(label), ty, count });
    let bytes = count as u64 * 8;
    let resolve = storage(gpu, &format!("{label} resolve"), bytes, wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC);
    (set, resolve, crate::readback::staging(gpu, &format!("{label} readback"), bytes))
}

/// A bind group of `bufs`, whole, at bindings 0, 1, ...
fn bind(gpu: &Gpu, layout: &wgpu::BindGroupLayout, bufs: &[&wgpu::Buffer]) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> =
        bufs.iter().enumerate().map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() }).collect();
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout, entries: &entries })
}

impl Renderer {
    pub fn new(gpu: Gpu, scene: &SceneFile, width: u32, height: u32, options: RenderOptions) -> Result<Renderer, RenderError> {
        let max = crate::limits::MAX_SIZE;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::Size(width, height));
        }
        use wgpu::BufferUsages as U;
        let rows = if options.single_rows { Rows::Single } else { Rows::of(&gpu) };
        let textured = (options.shade && !scene.textures().is_empty()).then_some(options.textures);
        let draw = DrawPipelines::new(&gpu.device, rows, textured);
        let boxtest = BoxTestPipelines::new(&gpu.device);
        let view_buf = storage(&gpu, "view", std::mem::size_of::<ViewUniform>() as u64, U::UNIFORM | U::COPY_DST);
        let index_buf = storage(&gpu, "pass indices", 4, U::INDEX | U::COPY_DST);
        let n = crate::limits::MAX_BOXES as u64;
        let boxes_buf = storage(&gpu, "boxes", n * std::mem::size_of::<GpuBox>() as u64, U::STORAGE | U::COPY_DST);
        let results_buf = storage(&gpu, "box results", n * 4, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        let results_staging = crate::readback::staging(&gpu, "box results readback", n * 4);
        let uses_buf = storage(&gpu, "pass uses", 64, U::STORAGE | U::COPY_DST);
        let no_normals = storage(&gpu, "no normals", 4, U::STORAGE);
        let no_texcoords = storage(&gpu, "no texcoords", 12, U::STORAGE);
        let atlas = crate::atlas::Atlas::new(&gpu, scene, options.shade);
        atlas.left_out.iter().for_each(|l| tracing::warn!("{l}"));
        let box_group = bind(&gpu, &boxtest.layout, &[&view_buf, &boxes_buf, &results_buf]);
        let target = Target::new(&gpu, width, height);
        let pyramid = Pyramid::new(&gpu, &target, &view_buf, &boxes_buf, &results_buf);
        let (queries, query_resolve, query_staging) = query_set(&gpu, "box queries", wgpu::QueryType::Occlusion, QUERIES);
        let fragments = wgpu::QueryType::PipelineStatistics(wgpu::PipelineStatisticsTypes::FRAGMENT_SHADER_INVOCATIONS);
        let fragment_query =
            gpu.features.contains(wgpu::Features::PIPELINE_STATISTICS_QUERY).then(|| query_set(&gpu, "fragments", fragments, 1));
        let timestamps =
            gpu.features.contains(wgpu::Features::TIMESTAMP_QUERY).then(|| query_set(&gpu, "pass times", wgpu::QueryType::Timestamp, 2));
        Ok(Renderer {
            fragment_query,
            timestamps,
            options,
            origin: scene.origin(),
            near: osw_cull::view::near_of(scene),
            nodes: scene.nodes().len(),
            queries,
            query_resolve,
            query_staging,
            pyramid,
            target,
            residency: Residency::new(options.residency_bytes, options.max_arena_bytes, options.shade),
            draw,
            boxtest,
            view_buf,
            uses_buf,
            draw_group: None,
            no_normals,
            no_texcoords,
            atlas,
            index_buf,
            boxes_buf,
            results_buf,
            results_staging,
            box_group,
            indices: Vec::new(),
            draws: Vec::new(),
            uses: Uses::new(rows, options.max_nodes),
            gathered: Gathered::default(),
            gpu_boxes: Vec::new(),
            spare_pyramid: None,
            gpu,
        })
    }

    pub fn options(&self) -> RenderOptions {
        self.options
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// The image size, pixels.
    pub fn width(&self) -> u32 {
        self.target.width
    }

    pub fn height(&self) -> u32 {
        self.target.height
    }

    /// Geometry uploads and evictions since the renderer was made.
    pub fn residency_stats(&self) -> ResidencyStats {
        self.residency.stats
    }

    /// Whether draws count their fragments: asked for, and the adapter can.
    pub fn counts_fragments(&self) -> bool {
        self.options.count_fragments && self.fragment_query.is_some()
    }

    /// Whether draws are timed on the GPU: asked for, and the adapter has timestamps.
    pub fn times_gpu(&self) -> bool {
        self.options.time_gpu && self.timestamps.is_some()
    }

    /// The view of `camera` with this scene's near plane (see [`osw_cull::view::near_of`]),
    /// drawing the cut of a cluster hierarchy at `tau`.
    pub fn view(&self, camera: &osw_scene::Camera, tau: f64) -> View {
        View::new(camera, self.origin, self.target.width, self.target.height, self.near).at_tau(tau)
    }

    /// Starts a frame: geometry used from here on is kept resident through the frame.
    pub fn begin_frame(&mut self) {
        self.residency.next_epoch();
    }

    /// The depth attachment as it is now, rows top first.
    pub fn read_depth(&self) -> Result<Vec<f32>, RenderError> {
        Ok(self.target.read_depth(&self.gpu)?)
    }

    /// The farthest-depth pyramid of the depth buffer read back, built in the storage of the
    /// last one given back ([`Renderer::give_back`]).
    pub fn depth_pyramid(&mut self) -> Result<osw_cull::hzb::Pyramid, RenderError> {
        let mut p = self.spare_pyramid.take().unwrap_or_default();
        let (w, h) = (self.target.width, self.target.height);
        p.rebuild(w, h, |d| self.target.read_depth_into(&self.gpu, d))?;
        Ok(p)
    }

    /// A pyramid no longer needed: the next [`Renderer::depth_pyramid`] is built in its storage.
    pub fn give_back(&mut self, p: osw_cull::hzb::Pyramid) {
        self.spare_pyramid = Some(p);
    }

    /// Draws the gathered indices in one call; counts them into `stats.triangles`, and their
    /// fragments into `stats.fragments` when [`Renderer::counts_fragments`]. A translucent
    /// layer keeps the depth when it clears.
    pub fn submit(&mut self, view: &View, pass: Pass, layer: Layer, load: Load, stats: &mut DrawStats) -> Result<(), RenderError> {
        // What is submitted, not what the node table says.
        stats.triangles = self.indices.len() as u64 / 3;
        let bytes = self.upload(view, pass, layer)?;
        stats.draws = self.draws.len().max(1) as u32;
        let drawn = bytes > 0 && self.bind_arena();
        let label = pass.label(layer);
        let mut enc = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        enc.push_debug_group(label);
        self.encode(&mut enc, pass, layer, load, drawn.then_some(bytes));
        enc.pop_debug_group();
        self.finish(enc, stats)
    }

    /// Writes the view, the pass's indices and its use table to their buffers, each grown to
    /// fit; returns the indices' bytes.
    fn upload(&mut self, view: &View, pass: Pass, layer: Layer) -> Result<u64, RenderError> {
        let bytes = self.indices.len() as u64 * 4;
        if bytes > self.index_buf.size() {
            let max = self.gpu.device.limits().max_buffer_size;
            if bytes > max {
                return Err(RenderError::TooManyTriangles(self.indices.len() as u64 / 3, max));
            }
            let size = bytes.next_power_of_two().min(max);
            self.index_buf = storage(&self.gpu, "pass indices", size, wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST);
        }
        let use_bytes = std::mem::size_of_val(self.uses.list.as_slice()) as u64;
        if use_bytes > self.uses_buf.size() {
            let size = use_bytes.next_power_of_two();
            self.uses_buf = storage(&self.gpu, "pass uses", size, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST);
        }
        self.split_textured(pass, layer);
        if pass == Pass::ColorOver && layer == Layer::Opaque {
            // Last triangle first, each triangle's corners in their order (see Pass::ColorOver).
            self.indices.reverse();
            self.indices.chunks_exact_mut(3).for_each(<[u32]>::reverse);
            let n = self.indices.len() as u32;
            self.draws = self.draws.iter().rev().map(|(r, t)| (n - r.end..n - r.start, *t)).collect();
        }
        let q = &self.gpu.queue;
        let level = self.options.texture_level;
        let draw = [pass.tint(), self.uses.shift, level.unwrap_or(0.0).to_bits(), u32::from(level.is_some())];
        q.write_buffer(&self.view_buf, 0, bytemuck::bytes_of(&ViewUniform { draw, ..ViewUniform::new(view) }));
        if bytes > 0 {
            q.write_buffer(&self.index_buf, 0, bytemuck::cast_slice(&self.indices));
            q.write_buffer(&self.uses_buf, 0, bytemuck::cast_slice(&self.uses.list));
        }
        Ok(bytes)
    }

    /// The pass's draws ([`Renderer::draws`]): a colour pass's opaque triangles of textured
    /// nodes after the others, each group drawn by its own pipeline (shaders/draw.wgsl,
    /// `TEXTURES`), in submission order otherwise kept; a translucent layer with any textured
    /// node is one textured draw, so that its far-to-near order holds.
    fn split_textured(&mut self, pass: Pass, layer: Layer) {
        let n = self.indices.len() as u32;
        let colour = matches!(pass, Pass::Color | Pass::Tinted(_) | Pass::ColorOver);
        let textured = |uses: &Uses, i: u32| uses.list[(i >> uses.shift) as usize].textured != 0;
        if !colour || !self.uses.list.iter().any(|u| u.textured != 0) {
            self.draws = vec![(0..n, false)];
            return;
        }
        if layer == Layer::Translucent {
            self.draws = vec![(0..n, true)];
            return;
        }
        // In place: the untextured triangles close up, the textured ones go after them.
        let (mut sampled, mut k) = (Vec::new(), 0);
        for at in (0..self.indices.len()).step_by(3) {
            if textured(&self.uses, self.indices[at]) {
                sampled.extend_from_slice(&self.indices[at..at + 3]);
            } else {
                self.indices.copy_within(at..at + 3, k);
                k += 3;
            }
        }
        self.indices.truncate(k);
        self.indices.extend_from_slice(&sampled);
        let k = k as u32;
        self.draws = [(0..k, false), (k..n, true)].into_iter().filter(|(r, _)| !r.is_empty()).collect();
    }

    /// Makes the draw's bind group again where the arena or the use table grew since the last
    /// draw; false while there is no arena (nothing resident to draw).
    fn bind_arena(&mut self) -> bool {
        let Some(arena) = self.residency.arena() else { return false };
        let normals = self.residency.normals().unwrap_or(&self.no_normals);
        let bound = [arena, &self.uses_buf, normals, self.residency.texcoords().unwrap_or(&self.no_texcoords)];
        if self.draw_group.as_ref().is_none_or(|(_, b)| b.iter().zip(bound).any(|(was, is)| was != is)) {
            let buffers = [&self.view_buf, bound[1], bound[0], bound[2], bound[3], &self.atlas.textures, &self.atlas.rects];
            let mut entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
                .collect();
            entries.push(wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(&self.atlas.pages) });
            entries.push(wgpu::BindGroupEntry { binding: 8, resource: wgpu::BindingResource::Sampler(&self.atlas.sampler) });
            let group = self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("draw"),
                layout: &self.draw.layout,
                entries: &entries,
            });
            self.draw_group = Some((group, bound.map(Clone::clone)));
        }
        true
    }

    /// Records the pass: its attachments cleared or loaded, the draw of `bytes` of indices
    /// (none: an empty pass, which still clears), and the queries asked for.
    fn encode(&self, enc: &mut wgpu::CommandEncoder, pass: Pass, layer: Layer, load: Load, bytes: Option<u64>) {
        let query = self.fragment_query.as_ref().filter(|_| self.options.count_fragments);
        let times = self.timestamps.as_ref().filter(|_| self.options.time_gpu);
        let color_load = |c| if load == Load::Clear { wgpu::LoadOp::Clear(c) } else { wgpu::LoadOp::Load };
        let color_view = match pass {
            Pass::Color | Pass::Tinted(_) | Pass::ColorOver => Some(&self.target.color),
            Pass::Item => Some(&self.target.item),
            Pass::Depth => None,
        };
        let color = color_view.map(|v| wgpu::RenderPassColorAttachment {
            view: v,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: color_load(if pass == Pass::Item { wgpu::Color::BLACK } else { SKY }),
                store: wgpu::StoreOp::Store,
            },
        });
        let colors = [color];
        let depth_load = if load == Load::Clear && layer == Layer::Opaque && pass != Pass::ColorOver {
            wgpu::LoadOp::Clear(0.0)
        } else {
            wgpu::LoadOp::Load
        };
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(pass.label(layer)),
            // The depth-only pass has no colour attachment at all (not an empty slot).
            color_attachments: if colors[0].is_some() { &colors } else { &[] },
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.target.depth,
                depth_ops: Some(wgpu::Operations { load: depth_load, store: wgpu::StoreOp::Store }),
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
        if let (Some(bytes), Some((group, _))) = (bytes, &self.draw_group) {
            rp.set_bind_group(0, group, &[]);
            rp.set_index_buffer(self.index_buf.slice(..bytes), wgpu::IndexFormat::Uint32);
            for (range, textured) in &self.draws {
                rp.set_pipeline(self.draw.pipeline(pass, layer, *textured));
                rp.draw_indexed(range.clone(), 0, 0..1);
            }
        }
        if query.is_some() {
            rp.end_pipeline_statistics_query();
        }
        drop(rp);
        if let Some((set, resolve, staging)) = query {
            enc.resolve_query_set(set, 0..1, resolve, 0);
            enc.copy_buffer_to_buffer(resolve, 0, staging, 0, Some(8));
        }
        if let Some((set, resolve, staging)) = times {
            enc.resolve_query_set(set, 0..2, resolve, 0);
            enc.copy_buffer_to_buffer(resolve, 0, staging, 0, Some(16));
        }
    }

    /// Submits the recorded pass and reads back what it counted and timed; waits for it unless
    /// the renderer keeps a draw in flight ([`RenderOptions::overlap`]).
    fn finish(&mut self, enc: wgpu::CommandEncoder, stats: &mut DrawStats) -> Result<(), RenderError> {
        let query = self.fragment_query.as_ref().filter(|_| self.options.count_fragments);
        let times = self.timestamps.as_ref().filter(|_| self.options.time_gpu);
        if self.options.overlap {
            self.gpu.wait()?;
        }
        self.gpu.queue.submit([enc.finish()]);
        match query {
            Some((_, _, staging)) => stats.fragments = crate::readback::read(&self.gpu, staging, 8, bytemuck::pod_read_unaligned::<u64>)?,
            None if !self.options.overlap => self.gpu.wait()?,
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
        let label = "depth pyramid";
        let mut enc = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        enc.push_debug_group(label);
        self.pyramid.encode_build(&self.target, &mut enc);
        enc.pop_debug_group();
        self.gpu.queue.submit([enc.finish()]);
    }

    /// Tests `boxes` (world space) against the occluders: the depth buffer as it is now (exact
    /// tests, read on the lines of `sampling`) or the pyramid last built from it. Appends one
    /// answer per box.
    pub fn test_boxes(
        &mut self,
        view: &View,
        boxes: impl IntoIterator<Item = osw_scene::Aabb>,
        test: BoxTest,
        sampling: Sampling,
        out: &mut Vec<Visibility>,
    ) -> Result<(), RenderError> {
        let mut words = Vec::new();
        self.test_raw(view, &mut boxes.into_iter(), test, sampling, &mut words)?;
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
        sampling: Sampling,
        out: &mut Vec<u32>,
    ) -> Result<(), RenderError> {
        self.gpu.queue.write_buffer(&self.view_buf, 0, bytemuck::bytes_of(&ViewUniform::new(view)));
        let chunk_len = if test == BoxTest::Queries { QUERIES } else { crate::limits::MAX_BOXES };
        loop {
            self.gpu_boxes.clear();
            for b in (&mut *boxes).take(chunk_len as usize) {
                let (lo, hi) = view.test_box(&b);
                let (lo, hi) = (lo.as_vec3(), hi.as_vec3());
                let (lines, first) = (sampling.lines as f32, sampling.first as f32);
                self.gpu_boxes.push(GpuBox { lo: lo.extend(lines).to_array(), hi: hi.extend(first).to_array() });
            }
            if self.gpu_boxes.is_empty() {
                return Ok(());
            }
            let n = self.gpu_boxes.len() as u32;
            self.gpu.queue.write_buffer(&self.boxes_buf, 0, bytemuck::cast_slice(&self.gpu_boxes));
            let mut enc = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(test.label()) });
            enc.push_debug_group(test.label());
            match test {
                BoxTest::Queries => {
                    let mut rp = self.box_pass(&mut enc, test, &self.boxtest.flag, Some(&self.queries));
                    for i in 0..n {
                        rp.begin_occlusion_query(i);
                        rp.draw(0..36, i..i + 1);
                        rp.end_occlusion_query();
                    }
                    drop(rp);
                    enc.resolve_query_set(&self.queries, 0..n, &self.query_resolve, 0);
                    enc.copy_buffer_to_buffer(&self.query_resolve, 0, &self.query_staging, 0, Some(n as u64 * 8));
                    enc.pop_debug_group();
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
                    self.box_pass(&mut enc, test, pipeline, None).draw(0..36, 0..n);
                }
            }
            enc.copy_buffer_to_buffer(&self.results_buf, 0, &self.results_staging, 0, Some(n as u64 * 4));
            enc.pop_debug_group();
            self.gpu.queue.submit([enc.finish()]);
            crate::readback::read(&self.gpu, &self.results_staging, n as u64 * 4, |bytes| {
                out.extend_from_slice(bytemuck::cast_slice(bytes))
            })?;
        }
    }

    /// A pass of `test` rasterising the boxes with `pipeline` against the depth buffer,
    /// counted by `queries` when given.
    fn box_pass<'a>(
        &'a self,
        enc: &'a mut wgpu::CommandEncoder,
        test: BoxTest,
        pipeline: &'a wgpu::RenderPipeline,
        queries: Option<&'a wgpu::QuerySet>,
    ) -> wgpu::RenderPass<'a> {
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(test.label()),
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
