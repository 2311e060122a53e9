//! The HC primitive (occlusion switch sec. 4.2 and alg. 4.1 line 6): node bounding boxes rasterised
//! against the occluder depth buffer, one instance per box, with forced early depth so that
//! only passing fragments write (see shaders/boxtest.wgsl). Exact per pixel: a box is visible
//! when any of its pixels is nearer than the occluders. With `count_pixels` each box gets its
//! number of passing front-face fragments (sec. 4.7.2).

use crate::draw::depth_state;

/// One box, camera-relative (`Box` in shaders/common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuBox {
    pub lo: [f32; 4],
    pub hi: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<GpuBox>() == 32);

pub struct BoxTestPipelines {
    pub layout: wgpu::BindGroupLayout,
    pub flag: wgpu::RenderPipeline,
    pub count: wgpu::RenderPipeline,
}

impl BoxTestPipelines {
    pub fn new(device: &wgpu::Device) -> BoxTestPipelines {
        let module = crate::shaders::module(device, "boxtest.wgsl", "", include_str!("shaders/boxtest.wgsl"));
        let buffer = |binding, ty, visibility| wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("boxtest"),
            entries: &[
                buffer(0, wgpu::BufferBindingType::Uniform, wgpu::ShaderStages::VERTEX),
                buffer(1, wgpu::BufferBindingType::Storage { read_only: true }, wgpu::ShaderStages::VERTEX),
                buffer(2, wgpu::BufferBindingType::Storage { read_only: false }, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("boxtest"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let make = |label: &str, count: bool| {
            let constants = [("count_pixels", if count { 1.0 } else { 0.0 })];
            let options = wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() };
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&pl),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_box"),
                    compilation_options: options.clone(),
                    buffers: &[],
                },
                // Front faces only: with the eye outside the box (boxes around the eye are not
                // tested) every back-face fragment lies behind a front-face fragment of the same
                // pixel, so it can never be the only one to pass. Halves the fill.
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    cull_mode: Some(wgpu::Face::Back),
                    ..Default::default()
                },
                // GreaterEqual: a box face exactly at the occluder's depth counts as visible.
                // A box face coplanar with a face of the node's own geometry (a slab, a crate)
                // rasterises from other triangles and can land a rounding step behind it: the
                // bias moves box fragments nearer (reversed Z: greater) by a few steps and more
                // at grazing angles, so a node drawn as an occluder never hides its own box.
                depth_stencil: Some(wgpu::DepthStencilState {
                    bias: wgpu::DepthBiasState { constant: 64, slope_scale: 4.0, clamp: 0.0 },
                    ..depth_state(false, wgpu::CompareFunction::GreaterEqual)
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_box"),
                    compilation_options: options,
                    targets: &[],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        BoxTestPipelines { flag: make("boxtest flag", false), count: make("boxtest count", true), layout }
    }
}
