//! The fast HC test: a farthest-depth pyramid built from the occluder depth buffer by compute
//! passes (shaders/depthreduce.comp.wgsl), and boxes tested against it by one compute dispatch
//! per batch (shaders/boxcull.comp.wgsl). Conservative, like the exact test, but it cannot count
//! visible pixels, so the LOD stop of occlusion switch sec. 4.7.2 does not apply with it.

use crate::device::Gpu;
use crate::target::Target;
use bytemuck::{Pod, Zeroable};

/// One pyramid level in the packed buffer (`Level` in shaders/common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Eq)]
pub struct Level {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    /// Texels from one row to the next: level 0 is a copy of the depth texture, whose rows
    /// are padded to 256 bytes.
    pub pitch: u32,
}

const _: () = assert!(std::mem::size_of::<Level>() == 16);

/// The level table for a `width` x `height` depth buffer: halving (rounding up) down to 1x1.
pub fn levels(width: u32, height: u32) -> Vec<Level> {
    let mut out = vec![Level { offset: 0, width, height, pitch: crate::target::padded_row(width * 4) / 4 }];
    while let Some(&l) = out.last().filter(|l| l.width > 1 || l.height > 1) {
        let (width, height) = (l.width.div_ceil(2), l.height.div_ceil(2));
        out.push(Level { offset: l.offset + l.pitch * l.height, width, height, pitch: width });
    }
    out
}

pub struct Pyramid {
    pub levels: Vec<Level>,
    buffer: wgpu::Buffer,
    reduce: wgpu::ComputePipeline,
    cull: wgpu::ComputePipeline,
    /// Each reduction dispatch's bind group and the level whose texels it is dispatched over.
    reduce_steps: Vec<(wgpu::BindGroup, Level)>,
    cull_group: wgpu::BindGroup,
    batch_buf: wgpu::Buffer,
}

fn entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry { binding, visibility: wgpu::ShaderStages::COMPUTE, ty, count: None }
}

fn buffer(ty: wgpu::BufferBindingType) -> wgpu::BindingType {
    wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None }
}

/// A compute pipeline of shaders/`label`.comp.wgsl (`src`) at `entry_point`, and the layout
/// of its one bind group, of `entries`.
fn pipeline(
    d: &wgpu::Device,
    label: &str,
    src: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
    entry_point: &str,
    constants: &[(&str, f64)],
) -> (wgpu::ComputePipeline, wgpu::BindGroupLayout) {
    let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries });
    let module = crate::shaders::module(d, &format!("{label}.comp.wgsl"), "", src);
    let pl = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pl),
        module: &module,
        entry_point: Some(entry_point),
        compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
        cache: None,
    });
    (pipeline, layout)
}

/// A bind group of `bufs`, whole, at bindings 0, 1, ...
fn bind(d: &wgpu::Device, label: &str, layout: &wgpu::BindGroupLayout, bufs: &[&wgpu::Buffer]) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> =
        bufs.iter().enumerate().map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() }).collect();
    d.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries: &entries })
}

/// The reduction's dispatches, each with the level whose texels it is dispatched over. One
/// small uniform per dispatch names its levels (1 and 2, 3 and 4, ...): the dispatches of one
/// frame go in one submission, so each needs its own.
fn reduce_steps(
    d: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    levels: &[Level],
    levels_buf: &wgpu::Buffer,
    pyramid_buf: &wgpu::Buffer,
) -> Vec<(wgpu::BindGroup, Level)> {
    use wgpu::util::DeviceExt;
    (1..levels.len() as u32)
        .step_by(2)
        .map(|k| {
            let two = u32::from(k + 1 < levels.len() as u32);
            let step = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("reduce step"),
                contents: bytemuck::cast_slice(&[k, two, 0, 0]),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            // One invocation per texel of the top level written.
            (bind(d, "depthreduce", layout, &[levels_buf, pyramid_buf, &step]), levels[(k + two) as usize])
        })
        .collect()
}

impl Pyramid {
    /// `view_buf`, `boxes_buf` and `results_buf` are the renderer's (shared with the exact test).
    pub fn new(gpu: &Gpu, target: &Target, view_buf: &wgpu::Buffer, boxes_buf: &wgpu::Buffer, results_buf: &wgpu::Buffer) -> Pyramid {
        use wgpu::BufferBindingType as B;
        use wgpu::util::DeviceExt;
        let d = &gpu.device;
        let levels = levels(target.width, target.height);
        let texels: u32 = levels.iter().map(|l| l.pitch * l.height).sum();
        let levels_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("pyramid levels"),
            contents: bytemuck::cast_slice(&levels),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let pyramid_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pyramid"),
            size: texels as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let batch_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cull batch"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let reduce_entries = [
            entry(0, buffer(B::Storage { read_only: true })),
            entry(1, buffer(B::Storage { read_only: false })),
            entry(2, buffer(B::Uniform)),
        ];
        let src = include_str!("shaders/depthreduce.comp.wgsl");
        let (reduce, reduce_layout) = pipeline(d, "depthreduce", src, &reduce_entries, "reduce", &[]);
        let reduce_steps = reduce_steps(d, &reduce_layout, &levels, &levels_buf, &pyramid_buf);
        let cull_entries = [
            entry(0, buffer(B::Uniform)),
            entry(1, buffer(B::Storage { read_only: true })),
            entry(2, buffer(B::Storage { read_only: false })),
            entry(3, buffer(B::Storage { read_only: true })),
            entry(4, buffer(B::Storage { read_only: true })),
            entry(5, buffer(B::Uniform)),
        ];
        let src = include_str!("shaders/boxcull.comp.wgsl");
        let finer = [("finer", osw_cull::hzb::PYRAMID_FINER as f64)];
        let (cull, cull_layout) = pipeline(d, "boxcull", src, &cull_entries, "cull", &finer);
        let cull_group = bind(d, "boxcull", &cull_layout, &[view_buf, boxes_buf, results_buf, &levels_buf, &pyramid_buf, &batch_buf]);
        Pyramid { levels, buffer: pyramid_buf, reduce, cull, reduce_steps, cull_group, batch_buf }
    }

    /// Records the reduction of the current depth buffer into the pyramid.
    pub fn encode_build(&self, target: &Target, enc: &mut wgpu::CommandEncoder) {
        target.encode_depth_copy(enc, &self.buffer);
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("depthreduce"), timestamp_writes: None });
        pass.set_pipeline(&self.reduce);
        for (group, l) in &self.reduce_steps {
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(l.width.div_ceil(8), l.height.div_ceil(8), 1);
        }
    }

    /// Records the test of the first `count` boxes of the box buffer into the results buffer.
    pub fn encode_cull(&self, gpu: &Gpu, enc: &mut wgpu::CommandEncoder, count: u32) {
        gpu.queue.write_buffer(&self.batch_buf, 0, bytemuck::cast_slice(&[count, self.levels.len() as u32, 0, 0]));
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("boxcull"), timestamp_writes: None });
        pass.set_pipeline(&self.cull);
        pass.set_bind_group(0, &self.cull_group, &[]);
        pass.dispatch_workgroups(count.div_ceil(64), 1, 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_table_packs_halving_levels() {
        let l = levels(5, 3);
        let dims: Vec<(u32, u32, u32, u32)> = l.iter().map(|l| (l.offset, l.width, l.height, l.pitch)).collect();
        // Level 0's rows are padded to 256 bytes, 64 texels.
        assert_eq!(dims, vec![(0, 5, 3, 64), (192, 3, 2, 3), (198, 2, 1, 2), (200, 1, 1, 1)]);
    }
}
