//! Drawing LOD nodes: one draw per pass over the vertex arena (see [`crate::residency`]), each
//! index naming a node's slot in the pass's use table and a vertex of its mesh
//! ([`crate::uses`]); the node picks its object from a per-node table. Passes:
//! colour + depth (RVG), depth only (OR's occluders), item ids + depth (exact visibility). All
//! use the same vertex shader, so a node covers the same pixels at the same depth in every
//! pass. A block's translucent clusters are a second layer: blended over the colour (or written
//! over the item ids), depth tested but never written, and never drawn in the depth pass.

use crate::target::{COLOR, DEPTH, ITEM};
use crate::uses::Rows;
use bytemuck::{Pod, Zeroable};

/// What a draw writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// Colour and depth, each object in its own colour.
    Color,
    /// Colour and depth, every node in this RGB colour (shaded): nodes coloured by state.
    Tinted([u8; 3]),
    /// Colour over the depth buffer as earlier passes left it (prev's RVG over its OR's and
    /// HC's depth): the opaque layer tested `GreaterEqual`, so that a surface drawn before
    /// passes again, its triangles submitted last to first. The last of surfaces tied in depth
    /// then keeps the pixel, which is the first in submission order, as under `Greater` in
    /// order: the image is the one a [`Pass::Color`] draw on a cleared buffer makes, provided
    /// what was drawn into the depth before is nowhere nearer than the nearest surface drawn
    /// now (it was drawn from the same set, or is hidden behind it). Clearing clears the colour
    /// only.
    ColorOver,
    Depth,
    Item,
}

/// Which of a node's clusters a draw takes (see `osw_scene::format::BlockRecord::opaque_clusters`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layer {
    Opaque,
    /// Depth tested, not written; colour passes blend with the model's alpha.
    Translucent,
}

/// What a draw does with its attachments first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Load {
    /// Colour to the sky, item ids to 0, depth to 0 (infinitely far). A translucent layer and
    /// [`Pass::ColorOver`] keep the depth.
    Clear,
    /// Draws over what is there.
    Keep,
}

/// The view uniform shared by all shaders.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ViewUniform {
    pub view_proj: [[f32; 4]; 4],
    pub offset: [f32; 4],
    /// x: the pass's tint, RGB in the low three bytes and 255 in the high one, or 0: each
    /// object in its own colour; y: the pass's [`crate::uses::Uses::shift`]; z: a texture
    /// level (f32 bits), forced where w is 1.
    pub draw: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<ViewUniform>() == 96);

impl ViewUniform {
    pub fn new(view: &osw_cull::View) -> ViewUniform {
        ViewUniform { view_proj: view.view_proj().to_cols_array_2d(), offset: view.offset().extend(0.0).to_array(), draw: [0; 4] }
    }
}

impl Pass {
    /// The name a debugger shows for a draw of this pass and layer.
    pub fn label(self, layer: Layer) -> &'static str {
        match (self, layer) {
            (Pass::Color, Layer::Opaque) => "color",
            (Pass::Tinted(_), Layer::Opaque) => "color tinted",
            (Pass::ColorOver, Layer::Opaque) => "color over depth",
            (Pass::Color | Pass::Tinted(_) | Pass::ColorOver, Layer::Translucent) => "color translucent",
            (Pass::Depth, _) => "depth",
            (Pass::Item, Layer::Opaque) => "item",
            (Pass::Item, Layer::Translucent) => "item translucent",
        }
    }

    /// The tint of this pass ([`ViewUniform::draw`]'s x).
    pub fn tint(self) -> u32 {
        match self {
            Pass::Tinted([r, g, b]) => u32::from_le_bytes([r, g, b, 255]),
            _ => 0,
        }
    }
}

/// The colour pipelines of one kind of surface: untextured, or textured (see `TEXTURES` in
/// shaders/draw.wgsl).
pub struct ColorPipelines {
    pub color: wgpu::RenderPipeline,
    pub color_over: wgpu::RenderPipeline,
    pub blend: wgpu::RenderPipeline,
}

pub struct DrawPipelines {
    pub layout: wgpu::BindGroupLayout,
    pub plain: ColorPipelines,
    /// None where the scene has no texture or the renderer shades nothing (OR and HC).
    pub textured: Option<ColorPipelines>,
    pub depth: wgpu::RenderPipeline,
    pub item: wgpu::RenderPipeline,
    pub item_over: wgpu::RenderPipeline,
}

pub fn depth_state(write: bool, compare: wgpu::CompareFunction) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

impl DrawPipelines {
    /// The pipelines whose vertex shader places instances with `rows`; textured surfaces
    /// sampled where `textured` is `Some(true)`, in each texture's mean colour where
    /// `Some(false)`, and no textured pipelines where `None`.
    pub fn new(device: &wgpu::Device, rows: Rows, textured: Option<bool>) -> DrawPipelines {
        let place = match rows {
            Rows::Exact => include_str!("shaders/place64.wgsl"),
            Rows::Single => include_str!("shaders/place32.wgsl"),
        };
        let src = format!("{}\n{place}", include_str!("shaders/draw.wgsl"));
        let module = crate::shaders::module(device, "draw.wgsl", "", &src);
        let item_body = format!("{src}\n{}", include_str!("shaders/item.frag.wgsl"));
        let item_module = crate::shaders::module(device, "item.frag.wgsl", "enable primitive_index;\n", &item_body);
        let entry = |binding, ty, vis| wgpu::BindGroupLayoutEntry { binding, visibility: vis, ty, count: None };
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let read = wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("draw"),
            // The view, the pass's use table, the vertex, normal and texcoord arenas, the texture
            // table, its rectangles, the atlas and its sampler (crate::atlas).
            entries: &[
                entry(
                    0,
                    wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
                    vf,
                ),
                entry(1, read, wgpu::ShaderStages::VERTEX),
                entry(2, read, wgpu::ShaderStages::VERTEX),
                entry(3, read, wgpu::ShaderStages::VERTEX),
                entry(4, read, wgpu::ShaderStages::VERTEX),
                entry(5, read, vf),
                entry(6, read, wgpu::ShaderStages::FRAGMENT),
                entry(
                    7,
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    wgpu::ShaderStages::FRAGMENT,
                ),
                entry(8, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering), wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("draw"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let make = |label: &str,
                    module: &wgpu::ShaderModule,
                    fs: Option<(&str, wgpu::TextureFormat)>,
                    layer: Layer,
                    compare,
                    textures: u32| {
            let constants = [("TEXTURES", textures as f64)];
            let compilation_options = wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() };
            let vs = if fs.is_some_and(|(_, f)| f == COLOR) { "vs_shade" } else { "vs_main" };
            let blend = (layer == Layer::Translucent && fs.is_some_and(|(_, f)| f == COLOR)).then_some(wgpu::BlendState::ALPHA_BLENDING);
            let targets = fs.map(|(_, f)| [Some(wgpu::ColorTargetState { format: f, blend, write_mask: wgpu::ColorWrites::ALL })]);
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&pl),
                vertex: wgpu::VertexState { module, entry_point: Some(vs), compilation_options: compilation_options.clone(), buffers: &[] },
                // No back-face culling: a single-sided surface's back faces are dropped while its
                // pass gathers them (osw_cull::cluster), the same way in every pass.
                primitive: wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::TriangleList, cull_mode: None, ..Default::default() },
                depth_stencil: Some(depth_state(layer == Layer::Opaque, compare)),
                multisample: Default::default(),
                fragment: fs.map(|(entry, _)| wgpu::FragmentState {
                    module,
                    entry_point: Some(entry),
                    compilation_options: compilation_options.clone(),
                    targets: targets.as_ref().map(|t| t.as_slice()).unwrap_or(&[]),
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        use wgpu::CompareFunction::{Greater, GreaterEqual};
        let colors = |textures: u32| ColorPipelines {
            color: make("draw color", &module, Some(("fs_color", COLOR)), Layer::Opaque, Greater, textures),
            color_over: make("draw color over", &module, Some(("fs_color", COLOR)), Layer::Opaque, GreaterEqual, textures),
            blend: make("draw blend", &module, Some(("fs_blend", COLOR)), Layer::Translucent, Greater, textures),
        };
        DrawPipelines {
            plain: colors(0),
            textured: textured.map(|sample| colors(if sample { 2 } else { 1 })),
            depth: make("draw depth", &module, None, Layer::Opaque, Greater, 0),
            item: make("draw item", &item_module, Some(("fs_item", ITEM)), Layer::Opaque, Greater, 0),
            item_over: make("draw item over", &item_module, Some(("fs_item", ITEM)), Layer::Translucent, Greater, 0),
            layout,
        }
    }

    /// The pipeline of `pass` for `layer`, for textured triangles or not; translucent clusters
    /// are never drawn into depth alone (they occlude nothing), so the depth pass has one.
    pub fn pipeline(&self, pass: Pass, layer: Layer, textured: bool) -> &wgpu::RenderPipeline {
        let colors = self.textured.as_ref().filter(|_| textured).unwrap_or(&self.plain);
        match (pass, layer) {
            (Pass::Color | Pass::Tinted(_), Layer::Opaque) => &colors.color,
            (Pass::ColorOver, Layer::Opaque) => &colors.color_over,
            (Pass::Color | Pass::Tinted(_) | Pass::ColorOver, Layer::Translucent) => &colors.blend,
            (Pass::Depth, _) => &self.depth,
            (Pass::Item, Layer::Opaque) => &self.item,
            (Pass::Item, Layer::Translucent) => &self.item_over,
        }
    }
}
