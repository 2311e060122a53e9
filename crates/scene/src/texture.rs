//! Base colour textures as a model's materials use them: decoded images, how each is sampled,
//! and where a vertex samples it. The build stores each image's mip chain ([`crate::mip`]) in
//! the scene file's texel region and a table of textures ([`crate::format::TextureRecord`]);
//! only the display reads them: the switch's nodes draw depth and ids, never a colour texel.

use bytemuck::{Pod, Zeroable};

/// Where a vertex samples its surface's texture: glTF's coordinates (u right, v down the
/// image, `KHR_texture_transform` applied) and the texture, an index into the scene's texture
/// table or [`NO_TEXTURE`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Texcoord {
    pub uv: [f32; 2],
    pub texture: u32,
}

/// The texture index of a vertex whose surface has none (a mesh merged with a textured one).
pub const NO_TEXTURE: u32 = u32::MAX;

impl Texcoord {
    pub const NONE: Texcoord = Texcoord { uv: [0.0; 2], texture: NO_TEXTURE };
}

impl Default for Texcoord {
    fn default() -> Texcoord {
        Texcoord::NONE
    }
}

/// How coordinates outside 0..1 fold back (glTF's wrapS and wrapT).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Wrap {
    #[default]
    Repeat = 0,
    Clamp = 1,
    Mirror = 2,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Filter {
    Nearest = 0,
    Linear = 1,
}

/// A glTF sampler: wrap modes of u and v, the filters within a level when magnified and
/// minified, and between levels (None: level 0 alone, as glTF's non-mipmap minFilters).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Sampler {
    pub wrap: [Wrap; 2],
    pub mag: Filter,
    pub min: Filter,
    pub mip: Option<Filter>,
}

impl Default for Sampler {
    /// glTF leaves the filters of a texture without a sampler to the renderer: trilinear.
    fn default() -> Sampler {
        Sampler { wrap: [Wrap::Repeat; 2], mag: Filter::Linear, min: Filter::Linear, mip: Some(Filter::Linear) }
    }
}

impl Sampler {
    /// As [`crate::format::TextureRecord::sampler`] packs it: a hex digit each of wrap u, wrap
    /// v, mag, min, and mip (0 none, 1 nearest, 2 linear), lowest first.
    pub fn packed(&self) -> u32 {
        let mip = self.mip.map_or(0, |f| f as u32 + 1);
        self.wrap[0] as u32 | (self.wrap[1] as u32) << 4 | (self.mag as u32) << 8 | (self.min as u32) << 12 | mip << 16
    }

    pub fn unpacked(v: u32) -> Option<Sampler> {
        let wrap = |d: u32| [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror].get(d as usize).copied();
        let filter = |d: u32| [Filter::Nearest, Filter::Linear].get(d as usize).copied();
        let mip = match v >> 16 {
            0 => None,
            d => Some(filter(d - 1)?),
        };
        let s = Sampler { wrap: [wrap(v & 15)?, wrap(v >> 4 & 15)?], mag: filter(v >> 8 & 15)?, min: filter(v >> 12 & 15)?, mip };
        (s.packed() == v).then_some(s)
    }
}

/// An image as decoded: RGBA8, colour sRGB-encoded, alpha straight, rows top first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Image {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[u8; 4]>,
}

/// A texture as a material uses it: an image, its sampler, and for a cut-out (glTF alphaMode
/// MASK) the alpha below which a texel is a hole, divided by the material's alpha factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texture {
    pub image: u32,
    pub sampler: Sampler,
    pub cutoff: Option<f32>,
}

/// A model's images and textures, each stored once.
#[derive(Clone, Debug, Default)]
pub struct Textures {
    pub images: Vec<Image>,
    pub textures: Vec<Texture>,
}

impl Textures {
    /// The index of `t`, added unless an equal one is there already.
    pub fn add(&mut self, t: Texture) -> u32 {
        let same = |o: &Texture| o.image == t.image && o.sampler == t.sampler && o.cutoff.map(f32::to_bits) == t.cutoff.map(f32::to_bits);
        match self.textures.iter().position(same) {
            Some(k) => k as u32,
            None => {
                self.textures.push(t);
                self.textures.len() as u32 - 1
            }
        }
    }

    pub fn is_empty(&self) -> bool {
        self.textures.is_empty()
    }
}

/// An image file's bytes (PNG or JPEG) decoded, within limits on its size.
pub fn decode(name: &str, bytes: &[u8]) -> Result<Image, String> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    (limits.max_image_width, limits.max_image_height, limits.max_alloc) = (Some(MAX_DECODED_SIDE), Some(MAX_DECODED_SIDE), Some(1 << 30));
    reader.limits(limits);
    let rgba = reader.decode().map_err(|e| e.to_string())?.into_rgba8();
    if rgba.width() == 0 || rgba.height() == 0 {
        return Err("an empty image".into());
    }
    let (width, height) = rgba.dimensions();
    Ok(Image { name: name.to_owned(), width, height, texels: bytemuck::allocation::pod_collect_to_vec(rgba.as_raw()) })
}

/// An image's mean colour, linear RGBA: RGB weighted by alpha (what a cut-out's transparent
/// texels hold is never seen), alpha the mean coverage. A surface is drawn in its factor times
/// this where textures are not sampled.
pub fn mean(image: &Image) -> [f32; 4] {
    let linear = srgb_to_linear_table();
    let mut sum = [0f64; 4];
    for p in &image.texels {
        let a = p[3] as f64 / 255.0;
        (0..3).for_each(|k| sum[k] += linear[p[k] as usize] as f64 * a);
        sum[3] += a;
    }
    let texels = image.texels.len().max(1) as f64;
    let rgb = |k: usize| if sum[3] > 0.0 { (sum[k] / sum[3]) as f32 } else { 0.0 };
    [rgb(0), rgb(1), rgb(2), (sum[3] / texels) as f32]
}

/// [`mean`], colour as sRGB bytes.
pub fn mean_srgb(image: &Image) -> [u8; 4] {
    let m = mean(image);
    [srgb8(m[0]), srgb8(m[1]), srgb8(m[2]), (m[3] * 255.0).round() as u8]
}

/// Largest image decoded, texels a side.
pub const MAX_DECODED_SIDE: u32 = 16384;

/// The linear value of each sRGB byte.
pub fn srgb_to_linear_table() -> [f32; 256] {
    std::array::from_fn(|v| srgb_to_linear(v as f32 / 255.0))
}

/// An sRGB-encoded channel (0 to 1) as linear light (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// A linear channel as sRGB-encoded (0 to 1).
pub fn linear_to_srgb(linear: f32) -> f32 {
    let c = linear.clamp(0.0, 1.0);
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// A linear channel as an sRGB byte.
pub fn srgb8(linear: f32) -> u8 {
    (linear_to_srgb(linear) * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_is_taken_in_linear_light_over_the_opaque_texels() {
        let image = |texels: Vec<[u8; 4]>| Image { name: String::new(), width: texels.len() as u32, height: 1, texels };
        // Black and white average to linear 0.5 (sRGB 188), not sRGB 128.
        let m = mean(&image(vec![[0, 0, 0, 255], [255, 255, 255, 255]]));
        assert!((m[0] - 0.5).abs() < 1e-6 && m[3] == 1.0, "{m:?}");
        assert_eq!(mean_srgb(&image(vec![[0, 0, 0, 255], [255, 255, 255, 255]]))[0], 188);
        // A fence: green where opaque, garbage where transparent; half the texels covered.
        let m = mean(&image(vec![[0, 255, 0, 255], [255, 0, 255, 0], [0, 255, 0, 255], [9, 9, 9, 0]]));
        assert_eq!(m, [0.0, 1.0, 0.0, 0.5]);
        assert!(decode("x", b"not an image").is_err());
    }

    #[test]
    fn samplers_pack_and_unpack() {
        let s = Sampler { wrap: [Wrap::Mirror, Wrap::Clamp], mag: Filter::Nearest, min: Filter::Linear, mip: Some(Filter::Nearest) };
        assert_eq!(Sampler::unpacked(s.packed()), Some(s));
        assert_eq!(Sampler::unpacked(Sampler::default().packed()), Some(Sampler::default()));
        assert_eq!(Sampler::unpacked(3), None, "wrap 3 is no mode");
        assert_eq!(Sampler::unpacked(1 << 20), None, "bits past the mip digit");
    }

    #[test]
    fn textures_are_stored_once() {
        let mut t = Textures::default();
        let a = Texture { image: 0, sampler: Sampler::default(), cutoff: None };
        assert_eq!(t.add(a), 0);
        assert_eq!(t.add(Texture { cutoff: Some(0.5), ..a }), 1);
        assert_eq!(t.add(a), 0);
    }
}
