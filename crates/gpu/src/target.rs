//! Offscreen attachments: colour (RVG frames), depth (reversed Z: cleared to 0, nearer is
//! greater), item ids (exact visibility), and their readback.

use crate::device::{Gpu, GpuError};

pub const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
pub const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
pub const ITEM: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Uint;

pub struct Target {
    pub width: u32,
    pub height: u32,
    pub color: wgpu::TextureView,
    pub depth: wgpu::TextureView,
    pub item: wgpu::TextureView,
    color_tex: wgpu::Texture,
    depth_tex: wgpu::Texture,
    item_tex: wgpu::Texture,
    /// Where every readback lands, sized for the widest texel (item ids): made once, since
    /// HC reads the depth back several times a frame.
    staging: wgpu::Buffer,
}

fn texture(gpu: &Gpu, label: &str, w: u32, h: u32, format: wgpu::TextureFormat, usage: wgpu::TextureUsages) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// Rows of a texture copy are padded to 256 bytes.
pub(crate) fn padded_row(bytes_per_row: u32) -> u32 {
    bytes_per_row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
}

impl Target {
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> Target {
        use wgpu::TextureUsages as U;
        let color_tex = texture(gpu, "color", width, height, COLOR, U::RENDER_ATTACHMENT | U::COPY_SRC);
        let depth_tex = texture(gpu, "depth", width, height, DEPTH, U::RENDER_ATTACHMENT | U::COPY_SRC);
        let item_tex = texture(gpu, "item", width, height, ITEM, U::RENDER_ATTACHMENT | U::COPY_SRC);
        Target {
            width,
            height,
            color: color_tex.create_view(&Default::default()),
            depth: depth_tex.create_view(&Default::default()),
            item: item_tex.create_view(&Default::default()),
            color_tex,
            depth_tex,
            item_tex,
            staging: crate::readback::staging(gpu, "readback", padded_row(width * 8) as u64 * height as u64),
        }
    }

    /// The colour attachment as tightly packed RGBA8 rows, top row first.
    pub fn read_color(&self, gpu: &Gpu) -> Result<Vec<u8>, GpuError> {
        let mut out = Vec::new();
        self.read(gpu, &self.color_tex, &mut out).map(|()| out)
    }

    /// The item attachment as (id + 1, triangle) pairs, row by row.
    pub fn read_item(&self, gpu: &Gpu) -> Result<Vec<[u32; 2]>, GpuError> {
        let mut out = Vec::new();
        self.read(gpu, &self.item_tex, &mut out).map(|()| out)
    }

    /// The depth attachment (reversed Z), row by row: the readback the `hzb` baseline makes
    /// (Peng 2014 sec. 5.3; occlusion switch avoids it).
    pub fn read_depth(&self, gpu: &Gpu) -> Result<Vec<f32>, GpuError> {
        let mut out = Vec::new();
        self.read_depth_into(gpu, &mut out).map(|()| out)
    }

    /// [`Target::read_depth`] into `out`'s storage (cleared first).
    pub fn read_depth_into(&self, gpu: &Gpu, out: &mut Vec<f32>) -> Result<(), GpuError> {
        self.read(gpu, &self.depth_tex, out)
    }

    /// Records a copy of the depth attachment into `buffer` from offset 0, rows padded as
    /// [`padded_row`] says.
    pub fn encode_depth_copy(&self, enc: &mut wgpu::CommandEncoder, buffer: &wgpu::Buffer) {
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.depth_tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::DepthOnly,
            },
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded_row(self.width * 4)), rows_per_image: None },
            },
            wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 },
        );
    }

    /// Texture `tex` into `out` (cleared first) as tightly packed texels of type `T` (RGBA8 as
    /// bytes), row by row.
    fn read<T: bytemuck::Pod>(&self, gpu: &Gpu, tex: &wgpu::Texture, out: &mut Vec<T>) -> Result<(), GpuError> {
        let aspect = if tex.format() == DEPTH { wgpu::TextureAspect::DepthOnly } else { wgpu::TextureAspect::All };
        let texel = tex.format().block_copy_size(Some(aspect)).unwrap_or(4);
        let row = padded_row(self.width * texel);
        let size = row as u64 * self.height as u64;
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo { texture: tex, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.staging,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: None },
            },
            wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 },
        );
        gpu.queue.submit([enc.finish()]);
        let tight = (self.width * texel) as usize;
        crate::readback::read(gpu, &self.staging, size, |b| {
            out.clear();
            out.reserve(tight / std::mem::size_of::<T>() * self.height as usize);
            // Mapped rows start 256-byte aligned.
            b.chunks(row as usize).for_each(|r| out.extend_from_slice(bytemuck::cast_slice(&r[..tight])));
        })
    }
}
