//! The scene file's texture table: each image's mip chain in the texel region and the textures
//! that name images with a sampler. As for the other tables, the target recomputes the hashes
//! first. A file `validate` accepts must be safe to read textures from: every chain lies in the
//! texel region, its levels tile it end to end (the atlas copies each level from where
//! `ImageRecord::level` says), and every texture names an image and a sampler there is.

use bytemuck::pod_read_unaligned;
use osw_scene::format::{IMAGE_BYTES, ImageRecord, TEXTURE_BYTES, TextureRecord};
use std::path::Path;

pub fn run(data: &[u8]) {
    let mut bytes = data.to_vec();
    crate::scene_tables::rehash(&mut bytes);
    let Ok(h) = osw_scene::file::validate(Path::new("fuzz.osw"), &bytes) else { return };
    let record = |at: u64| &bytes[at as usize..];
    let images: Vec<ImageRecord> =
        (0..h.image_count as u64).map(|k| pod_read_unaligned(&record(h.images_offset + k * IMAGE_BYTES)[..IMAGE_BYTES as usize])).collect();
    let textures_at = h.images_offset + h.image_count as u64 * IMAGE_BYTES;
    let textures: Vec<TextureRecord> = (0..h.texture_count as u64)
        .map(|k| pod_read_unaligned(&record(textures_at + k * TEXTURE_BYTES)[..TEXTURE_BYTES as usize]))
        .collect();
    for m in &images {
        let mut end = 0;
        for k in 0..m.levels {
            let (w, h, at) = m.level(k);
            assert_eq!(at, end, "level {k} of {m:?} does not follow the one before");
            end = at + w as u64 * h as u64 * 4;
        }
        assert_eq!(end, m.byte_len(), "the levels of {m:?} do not tile its chain");
        assert!(m.offset + m.byte_len() <= h.texels_bytes, "{m:?} lies past the texel region");
        assert_eq!(m.level(m.levels - 1).0.max(m.level(m.levels - 1).1), 1, "{m:?} does not end at one texel");
    }
    for t in &textures {
        assert!(t.image < h.image_count && osw_scene::texture::Sampler::unpacked(t.sampler).is_some(), "{t:?}");
    }
}
