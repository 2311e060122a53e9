//! Base colour textures read as their mean colour. Until textures are sampled, a textured
//! surface is drawn in its factor times its texture's mean, in linear colour, rather than in
//! its factor alone (glTF's default factor is white): a meadow green, a road grey. An image
//! that cannot be read (a missing file, KTX2, past the limits) leaves its surfaces in their
//! factor, and the importer names it.

use std::borrow::Cow;
use std::path::Path;

/// Largest image read, texels a side, and bytes its decoding may allocate.
const MAX_SIDE: u32 = 16384;
const MAX_ALLOC: u64 = 1 << 30;

/// A texture's mean colour, linear RGBA: RGB weighted by alpha (what a cut-out's transparent
/// texels hold is never seen), alpha the mean coverage.
pub type Mean = [f32; 4];

/// Per image of `doc`: its mean, or why it cannot be read.
pub fn of_images(doc: &gltf::Document, buffers: &[&[u8]], base: &Path) -> Vec<Result<Mean, String>> {
    doc.images().map(|image| encoded(&image, buffers, base).and_then(|bytes| mean(&bytes))).collect()
}

/// The mean of the image file at `path` (an OBJ material's map_Kd).
pub fn of_file(path: &Path) -> Result<Mean, String> {
    mean(&std::fs::read(path).map_err(|e| e.to_string())?)
}

/// An image's encoded bytes: a buffer view, a data URI or a file beside the model.
fn encoded<'a>(image: &gltf::Image, buffers: &[&'a [u8]], base: &Path) -> Result<Cow<'a, [u8]>, String> {
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let buffer = buffers.get(view.buffer().index()).ok_or("its buffer is missing")?;
            let bytes = buffer.get(view.offset()..view.offset().saturating_add(view.length()));
            bytes.map(Cow::Borrowed).ok_or_else(|| "its view lies past its buffer".into())
        }
        gltf::image::Source::Uri { uri, .. } => match uri.strip_prefix("data:") {
            Some(rest) => {
                let (_, data) = rest.split_once(";base64,").ok_or("a data URI that is not base64")?;
                base64::decode(data).map(Cow::Owned).map_err(|e| format!("its data URI: {e}"))
            }
            None => std::fs::read(base.join(uri)).map(Cow::Owned).map_err(|e| e.to_string()),
        },
    }
}

fn mean(bytes: &[u8]) -> Result<Mean, String> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    (limits.max_image_width, limits.max_image_height, limits.max_alloc) = (Some(MAX_SIDE), Some(MAX_SIDE), Some(MAX_ALLOC));
    reader.limits(limits);
    let rgba = reader.decode().map_err(|e| e.to_string())?.into_rgba8();
    let linear: [f64; 256] = std::array::from_fn(|v| srgb_to_linear(v as f64 / 255.0));
    let mut sum = [0f64; 4];
    for p in rgba.pixels() {
        let a = p[3] as f64 / 255.0;
        (0..3).for_each(|k| sum[k] += linear[p[k] as usize] * a);
        sum[3] += a;
    }
    let texels = rgba.width() as f64 * rgba.height() as f64;
    if texels == 0.0 {
        return Err("an empty image".into());
    }
    let rgb = |k: usize| if sum[3] > 0.0 { (sum[k] / sum[3]) as f32 } else { 0.0 };
    Ok([rgb(0), rgb(1), rgb(2), (sum[3] / texels) as f32])
}

/// An sRGB-encoded channel (0 to 1) as linear light.
fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// A linear channel as sRGB-encoded (0 to 1).
pub fn linear_to_srgb(linear: f32) -> f32 {
    let c = linear.clamp(0.0, 1.0);
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG of `texels` (RGBA8, `w` wide).
    fn png(texels: &[[u8; 4]], w: u32) -> Vec<u8> {
        let img = image::RgbaImage::from_raw(w, texels.len() as u32 / w, texels.concat()).unwrap();
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    #[test]
    fn the_mean_is_taken_in_linear_light_over_the_opaque_texels() {
        // Black and white average to linear 0.5 (sRGB 188), not sRGB 128.
        let m = mean(&png(&[[0, 0, 0, 255], [255, 255, 255, 255]], 2)).unwrap();
        assert!((m[0] - 0.5).abs() < 1e-6 && m[3] == 1.0, "{m:?}");
        // A fence: green where opaque, garbage where transparent; half the texels covered.
        let m = mean(&png(&[[0, 255, 0, 255], [255, 0, 255, 0], [0, 255, 0, 255], [9, 9, 9, 0]], 2)).unwrap();
        assert_eq!(m, [0.0, 1.0, 0.0, 0.5]);
        assert!(mean(b"not an image").is_err());
    }
}
