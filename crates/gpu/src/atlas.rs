//! The scene's textures on the GPU: every level of every image's mip chain packed as a
//! rectangle into the pages of one sRGB `texture_2d_array`, and a table that says where each
//! texture's levels lie. One binding serves every texture, so that a pass stays one draw:
//! lavapipe has no descriptor indexing and binds at most 128 sampled images a stage, fewer
//! than a textured model's textures (forza: 129). The shader wraps coordinates itself (glTF's
//! wrap modes per axis, shaders/draw.wgsl `texel`) and lets the texture unit filter within a
//! level: each level is stored with a gutter of one texel around it holding the texels its
//! wrap mode puts there, so that a bilinear footprint at a level's edge reads what the
//! sampler's wrap mode would, never the neighbouring rectangle. An image sampled both repeated
//! and clamped along an axis is stored once per kind of gutter.

use crate::device::Gpu;
use bytemuck::{Pod, Zeroable};
use osw_scene::SceneFile;
use osw_scene::texture::{Sampler, Wrap};

/// Where one level lies: its page and its top-left texel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub page: u32,
    pub x: u32,
    pub y: u32,
}

/// Packs rectangles of `sizes` (each side at most `page`) into pages of `page` x `page`
/// texels, shelf by shelf, tallest first; returns each one's place, in the order given.
pub fn pack(sizes: &[(u32, u32)], page: u32) -> Vec<Rect> {
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&k| (std::cmp::Reverse(sizes[k].1), std::cmp::Reverse(sizes[k].0)));
    let mut out = vec![Rect { page: 0, x: 0, y: 0 }; sizes.len()];
    let (mut at, mut shelf) = (Rect { page: 0, x: 0, y: 0 }, 0);
    for k in order {
        let (w, h) = sizes[k];
        debug_assert!(w <= page && h <= page);
        if at.x + w > page {
            (at.x, at.y, shelf) = (0, at.y + shelf, 0);
        }
        if at.y + h > page {
            (at.page, at.x, at.y, shelf) = (at.page + 1, 0, 0, 0);
        }
        out[k] = at;
        at.x += w;
        shelf = shelf.max(h);
    }
    out
}

/// Texels of a gutter: one past either edge of an axis of `n`, as `wrap` folds it back.
fn gutter_source(i: i64, n: i64, wrap: Wrap) -> usize {
    match (wrap, i < 0) {
        (Wrap::Repeat, true) => n as usize - 1,
        (Wrap::Repeat, false) if i >= n => 0,
        _ => i.clamp(0, n - 1) as usize,
    }
}

/// A `w` x `h` level of RGBA8 `texels` with a one-texel gutter around it: (w + 2) x (h + 2),
/// each gutter texel the one its axis's wrap mode folds it to (a mirror's edge folds onto the
/// edge texel, as a clamp's does).
pub fn with_gutter(texels: &[u8], w: u32, h: u32, wrap: [Wrap; 2]) -> Vec<u8> {
    let (w, h) = (w as i64, h as i64);
    let mut out = Vec::with_capacity(((w + 2) * (h + 2) * 4) as usize);
    for y in -1..=h {
        let sy = gutter_source(y, h, wrap[1]);
        for x in -1..=w {
            let at = (sy * w as usize + gutter_source(x, w, wrap[0])) * 4;
            out.extend_from_slice(&texels[at..at + 4]);
        }
    }
    out
}

/// Which gutters a wrap mode needs: repeat's (the opposite edge) or the edge's own.
fn gutter_kind(wrap: [Wrap; 2]) -> [Wrap; 2] {
    wrap.map(|w| if w == Wrap::Repeat { Wrap::Repeat } else { Wrap::Clamp })
}

/// One texture as the shader reads it (`TextureInfo` in shaders/draw.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuTexture {
    /// Its level 0's entry in the rectangle table; the levels follow.
    pub rects: u32,
    /// 0 where the texture is not resident: drawn in its mean colour.
    pub levels: u32,
    /// log2 of level 0's width, and of its height in the next byte.
    pub size: u32,
    pub sampler: u32,
    /// Below this alpha a cut-out's texel is a hole; negative: not a cut-out.
    pub cutoff: f32,
    /// The image's mean colour, RGBA8 sRGB.
    pub mean: u32,
    pub pad: [u32; 2],
}

/// The textures of a scene on the GPU, and what of them could not be made resident.
pub struct Atlas {
    pub pages: wgpu::TextureView,
    /// Bilinear within a level; the shader wraps and picks levels.
    pub sampler: wgpu::Sampler,
    pub textures: wgpu::Buffer,
    /// `[x | y << 16, page]` per level of each resident texture.
    pub rects: wgpu::Buffer,
    /// Texel bytes resident.
    pub bytes: u64,
    /// Why textures are drawn in their mean colour instead, if any are.
    pub left_out: Vec<String>,
}

/// Smallest page side: small textures share a page rather than each take one.
const MIN_PAGE: u32 = 1024;

impl Atlas {
    /// Uploads every image of `scene` whose chain reads back good, where `upload`; a scene
    /// without textures (or not uploaded) gets a one-texel page and one empty texture, which
    /// nothing names.
    pub fn new(gpu: &Gpu, scene: &SceneFile, upload: bool) -> Atlas {
        let (images, textures) = if upload { (scene.images(), scene.textures()) } else { (&[][..], &[][..]) };
        let limits = gpu.device.limits();
        // Each image once per kind of gutter its textures need, in the order textures name them.
        let mut chains: Vec<(u32, [Wrap; 2])> = Vec::new();
        let chain_of: Vec<usize> = textures
            .iter()
            .map(|t| {
                let key = (t.image, gutter_kind(Sampler::unpacked(t.sampler).map_or([Wrap::Repeat; 2], |s| s.wrap)));
                chains.iter().position(|c| *c == key).unwrap_or_else(|| {
                    chains.push(key);
                    chains.len() - 1
                })
            })
            .collect();
        let side = |k: u32| images[k as usize].width.max(images[k as usize].height) + 2;
        let largest = chains.iter().map(|c| side(c.0)).max().unwrap_or(1);
        let page = largest.max(MIN_PAGE).min(limits.max_texture_dimension_2d);
        let mut left_out = Vec::new();
        let fits: Vec<bool> = chains.iter().map(|c| side(c.0) <= page).collect();
        // Every level of every chain that fits a page, gutters included.
        let sizes: Vec<(u32, u32)> = chains
            .iter()
            .zip(&fits)
            .filter(|(_, f)| **f)
            .flat_map(|(c, _)| {
                let m = &images[c.0 as usize];
                (0..m.levels).map(|k| m.level(k))
            })
            .map(|(w, h, _)| (w + 2, h + 2))
            .collect();
        let mut places = pack(&sizes, page);
        let pages = places.iter().map(|r| r.page + 1).max().unwrap_or(1);
        let layers = pages.min(limits.max_texture_array_layers);
        if pages > layers {
            left_out.push(format!("textures past {layers} pages of {page}x{page} texels (the device's most): drawn in their mean colour"));
        }
        let empty = chains.is_empty();
        let atlas = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("texture atlas"),
            size: wgpu::Extent3d {
                width: if empty { 1 } else { page },
                height: if empty { 1 } else { page },
                depth_or_array_layers: layers,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        // Per chain: its first rectangle, where all its levels are resident.
        let mut first = vec![None; chains.len()];
        let (mut rects, mut bytes, mut next) = (Vec::new(), 0u64, 0usize);
        for (k, &(image, wrap)) in chains.iter().enumerate() {
            let m = &images[image as usize];
            if !fits[k] {
                left_out.push(format!("image {image} of {}x{} texels: larger than a page of {page}", m.width, m.height));
                continue;
            }
            let mine = &mut places[next..next + m.levels as usize];
            next += m.levels as usize;
            if mine.iter().any(|r| r.page >= layers) {
                continue;
            }
            let texels = match scene.texels(image) {
                Ok(t) => t,
                Err(e) => {
                    left_out.push(e.to_string());
                    continue;
                }
            };
            first[k] = Some(rects.len() as u32);
            for (level, r) in mine.iter().enumerate() {
                let (w, h, at) = m.level(level as u32);
                let data = with_gutter(&texels[at as usize..(at + w as u64 * h as u64 * 4) as usize], w, h, wrap);
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &atlas,
                        mip_level: 0,
                        origin: wgpu::Origin3d { x: r.x, y: r.y, z: r.page },
                        aspect: wgpu::TextureAspect::All,
                    },
                    &data,
                    wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some((w + 2) * 4), rows_per_image: Some(h + 2) },
                    wgpu::Extent3d { width: w + 2, height: h + 2, depth_or_array_layers: 1 },
                );
                // The level itself, inside its gutter.
                rects.push([(r.x + 1) | (r.y + 1) << 16, r.page]);
                bytes += data.len() as u64;
            }
        }
        let table: Vec<GpuTexture> = textures
            .iter()
            .zip(&chain_of)
            .map(|(t, &c)| {
                let m = &images[t.image as usize];
                let (rects, levels) = first[c].map_or((0, 0), |r| (r, m.levels));
                let size = m.width.ilog2() | m.height.ilog2() << 8;
                GpuTexture { rects, levels, size, sampler: t.sampler, cutoff: t.cutoff, mean: u32::from_le_bytes(t.mean), pad: [0; 2] }
            })
            .collect();
        let table = if table.is_empty() { vec![GpuTexture::zeroed()] } else { table };
        let rects = if rects.is_empty() { vec![[0u32; 2]] } else { rects };
        Atlas {
            pages: atlas
                .create_view(&wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::D2Array), ..Default::default() }),
            sampler: gpu.device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("texture atlas"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
            textures: filled(gpu, "textures", bytemuck::cast_slice(&table)),
            rects: filled(gpu, "texture rects", bytemuck::cast_slice(&rects)),
            bytes,
            left_out,
        }
    }
}

fn filled(gpu: &Gpu, label: &str, data: &[u8]) -> wgpu::Buffer {
    let buf = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: data.len() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&buf, 0, data);
    buf
}

#[cfg(test)]
mod tests {
    use super::*;

    fn overlaps(a: (Rect, (u32, u32)), b: (Rect, (u32, u32))) -> bool {
        let ((ra, (wa, ha)), (rb, (wb, hb))) = (a, b);
        ra.page == rb.page && ra.x < rb.x + wb && rb.x < ra.x + wa && ra.y < rb.y + hb && rb.y < ra.y + ha
    }

    #[test]
    fn packed_rectangles_lie_in_their_pages_apart() {
        // A few chains of mixed sizes: every level of each.
        let mut sizes = Vec::new();
        for (w, h) in [(256u32, 256u32), (512, 128), (64, 64), (32, 256), (1024, 1024), (8, 8), (256, 64)] {
            sizes.extend((0..w.max(h).ilog2() + 1).map(|k| ((w >> k).max(1), (h >> k).max(1))));
        }
        let places = pack(&sizes, 1024);
        for (k, (r, (w, h))) in places.iter().zip(&sizes).enumerate() {
            assert!(r.x + w <= 1024 && r.y + h <= 1024, "{k}: {r:?} {w}x{h}");
            for j in 0..k {
                assert!(!overlaps((*r, (*w, *h)), (places[j], sizes[j])), "{k} and {j} overlap");
            }
        }
        // Packed tightly enough: the 1024 square fills one page, the rest fit in one more.
        assert_eq!(places.iter().map(|r| r.page).max(), Some(1));
    }

    #[test]
    fn gutters_hold_what_each_wrap_mode_folds_to() {
        // A 3x2 level whose texel (x, y) holds x + 10 y in red.
        let level: Vec<u8> = (0..2u8).flat_map(|y| (0..3u8).flat_map(move |x| [x + 10 * y, 0, 0, 255])).collect();
        let red = |g: &[u8], x: usize, y: usize| g[(y * 5 + x) * 4];
        // Sampling the padded level at texel (x, y) of the gutter's frame, -1..=n.
        let at = |g: &[u8], x: i32, y: i32| red(g, (x + 1) as usize, (y + 1) as usize);
        let repeat = with_gutter(&level, 3, 2, [Wrap::Repeat, Wrap::Repeat]);
        assert_eq!(repeat.len(), 5 * 4 * 4);
        for y in 0..2 {
            for x in 0..3 {
                assert_eq!(at(&repeat, x, y), x as u8 + 10 * y as u8, "the level itself at {x},{y}");
            }
        }
        assert_eq!([at(&repeat, -1, 0), at(&repeat, 3, 1), at(&repeat, 1, -1), at(&repeat, 2, 2)], [2, 10, 11, 2]);
        assert_eq!(at(&repeat, -1, -1), 12, "a corner wraps along both axes");
        let edge = with_gutter(&level, 3, 2, [Wrap::Clamp, Wrap::Mirror]);
        assert_eq!([at(&edge, -1, 0), at(&edge, 3, 1), at(&edge, 1, -1), at(&edge, 2, 2), at(&edge, 3, 2)], [0, 12, 1, 12, 12]);
        // Mixed: repeated along u, clamped along v.
        let mixed = with_gutter(&level, 3, 2, [Wrap::Repeat, Wrap::Clamp]);
        assert_eq!([at(&mixed, -1, -1), at(&mixed, 3, 2)], [2, 10]);
    }
}
