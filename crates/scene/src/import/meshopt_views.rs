//! EXT_meshopt_compression: buffer views whose bytes are meshoptimizer streams (gltfpack `-cc`).
//! Each such view is decoded into its place in the view's own buffer (the file's fallback
//! buffer, which has no data of its own), so that accessors then read it as any other view.

use super::ParseError;
use super::gltf_raw::{MeshoptView, Raw};

/// A compressed view may claim at most this many decoded bytes per compressed byte (plus a
/// block): meshoptimizer's codecs stay far below it (a vertex stream needs at least 2 bits per
/// 16 bytes, an index stream a byte per triangle), so a larger claim is a corrupt file, not a
/// reason to allocate gigabytes.
const MAX_RATIO: usize = 256;
const SLACK: usize = 1 << 16;

/// The bytes each fallback buffer must hold: the end of the last compressed view decoded into
/// it (0 for other buffers).
pub fn fallback_sizes(doc: &gltf::Document, raw: &Raw) -> Vec<usize> {
    let mut need = vec![0usize; doc.buffers().len()];
    for view in doc.views() {
        if raw.buffer_views.get(view.index()).is_some_and(|v| v.extensions.meshopt.is_some()) {
            let end = view.offset().saturating_add(view.length());
            need[view.buffer().index()] = need[view.buffer().index()].max(end);
        }
    }
    need
}

/// Decodes every compressed view of `doc` into `buffers`.
pub fn decode_views(doc: &gltf::Document, raw: &Raw, buffers: &mut [Vec<u8>]) -> Result<(), ParseError> {
    for view in doc.views() {
        let Some(m) = raw.buffer_views.get(view.index()).and_then(|v| v.extensions.meshopt.as_ref()) else { continue };
        let place = format!("bufferView {} (EXT_meshopt_compression {} {})", view.index(), m.mode, m.filter.as_deref().unwrap_or("NONE"));
        let bad = |what: String| ParseError::new(what).at(&place);
        let src = buffers
            .get(m.buffer)
            .and_then(|b| b.get(m.byte_offset..m.byte_offset.checked_add(m.byte_length)?))
            .ok_or_else(|| bad(format!("its {} compressed bytes at {} reach past buffer {}", m.byte_length, m.byte_offset, m.buffer)))?;
        let n =
            m.count.checked_mul(m.byte_stride).filter(|&n| n <= view.length()).ok_or_else(|| {
                bad(format!("{} elements of {} bytes do not fit the view's {} bytes", m.count, m.byte_stride, view.length()))
            })?;
        if n > src.len().saturating_mul(MAX_RATIO) + SLACK {
            return Err(bad(format!("claims {n} decoded bytes from {} compressed: not a meshopt stream", src.len())));
        }
        let decoded = decode(m, src).map_err(|e| e.at(&place))?;
        let dst = buffers[view.buffer().index()]
            .get_mut(view.offset()..view.offset() + n)
            .ok_or_else(|| bad(format!("the view reaches past buffer {}", view.buffer().index())))?;
        dst.copy_from_slice(&bytemuck::cast_slice::<u32, u8>(&decoded)[..n]);
    }
    Ok(())
}

/// Decodes one view's stream and filter (EXT_meshopt_compression, "Decoding"). Words of 4
/// bytes keep the filters' element types aligned.
fn decode(m: &MeshoptView, src: &[u8]) -> Result<Vec<u32>, ParseError> {
    let (count, stride) = (m.count, m.byte_stride);
    let bad = |e: meshopt::Error| ParseError::caused("corrupt or truncated stream", e);
    let words: Vec<u32> = match (m.mode.as_str(), stride) {
        ("ATTRIBUTES", s) if s % 4 == 0 && (4..=256).contains(&s) => {
            let mut out = vec![0u32; count * s / 4];
            // The crate's decode_vertex_buffer takes the stride from a type's size; a view's
            // stride is any multiple of 4 up to 256, so the C decoder is called with it.
            // SAFETY: `out` holds count * s bytes, exactly what the decoder writes for `count`
            // vertices of `s` bytes, and it reads at most `src.len()` bytes of `src`.
            let rc = unsafe { meshopt::ffi::meshopt_decodeVertexBuffer(out.as_mut_ptr().cast(), count, s, src.as_ptr(), src.len()) };
            if rc != 0 {
                return Err(ParseError::new(format!("corrupt or truncated vertex stream (meshopt code {rc})")));
            }
            out
        }
        ("TRIANGLES", 2) if count % 3 == 0 => widen16(meshopt::decode_index_buffer::<u16>(src, count).map_err(bad)?),
        ("TRIANGLES", 4) if count % 3 == 0 => meshopt::decode_index_buffer::<u32>(src, count).map_err(bad)?,
        ("INDICES", 2) => widen16(meshopt::decode_index_sequence::<u16>(src, count).map_err(bad)?),
        ("INDICES", 4) => meshopt::decode_index_sequence::<u32>(src, count).map_err(bad)?,
        (mode, s) => return Err(ParseError::new(format!("mode {mode} with {count} elements of {s} bytes is not a valid combination"))),
    };
    filter(m, words)
}

/// u16 indices packed two to a word, in the byte order of the view.
fn widen16(v: Vec<u16>) -> Vec<u32> {
    let mut w = vec![0u32; v.len().div_ceil(2)];
    bytemuck::cast_slice_mut::<u32, u16>(&mut w)[..v.len()].copy_from_slice(&v);
    w
}

fn filter(m: &MeshoptView, mut w: Vec<u32>) -> Result<Vec<u32>, ParseError> {
    let f = m.filter.as_deref().unwrap_or("NONE");
    if f != "NONE" && m.mode != "ATTRIBUTES" {
        return Err(ParseError::new(format!("filter {f} on mode {} (filters apply to ATTRIBUTES only)", m.mode)));
    }
    match (f, m.byte_stride) {
        ("NONE", _) => {}
        ("OCTAHEDRAL", 4) => meshopt::decode_filter_oct::<i8>(bytemuck::cast_slice_mut(&mut w)),
        ("OCTAHEDRAL", 8) => meshopt::decode_filter_oct::<i16>(bytemuck::cast_slice_mut(&mut w)),
        ("QUATERNION", 8) => meshopt::decode_filter_quat(bytemuck::cast_slice_mut(&mut w)),
        ("COLOR", 4) => meshopt::decode_filter_color::<i8>(bytemuck::cast_slice_mut(&mut w)),
        ("COLOR", 8) => meshopt::decode_filter_color::<i16>(bytemuck::cast_slice_mut(&mut w)),
        ("EXPONENTIAL", 4) => meshopt::decode_filter_exp::<1>(bytemuck::cast_slice_mut(&mut w)),
        ("EXPONENTIAL", 8) => meshopt::decode_filter_exp::<2>(bytemuck::cast_slice_mut(&mut w)),
        ("EXPONENTIAL", 12) => meshopt::decode_filter_exp::<3>(bytemuck::cast_slice_mut(&mut w)),
        ("EXPONENTIAL", 16) => meshopt::decode_filter_exp::<4>(bytemuck::cast_slice_mut(&mut w)),
        (f, s) => return Err(ParseError::new(format!("filter {f} with a {s}-byte stride is not one EXT_meshopt_compression defines"))),
    }
    Ok(w)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(mode: &str, count: usize, stride: usize, filter: Option<&str>) -> MeshoptView {
        MeshoptView { mode: mode.into(), count, byte_stride: stride, filter: filter.map(str::to_owned), ..Default::default() }
    }

    #[test]
    fn round_trips_vertices_and_indices() {
        let verts: Vec<[u16; 4]> = (0..100u16).map(|i| [i, i * 3, 65535 - i, 0]).collect();
        let enc = meshopt::encode_vertex_buffer(&verts).unwrap();
        let out = decode(&view("ATTRIBUTES", 100, 8, None), &enc).unwrap();
        assert_eq!(bytemuck::cast_slice::<u32, [u16; 4]>(&out), &verts[..]);
        let idx: Vec<u32> = (0..99).flat_map(|i| [i, i + 1, (i + 2) % 100]).collect();
        let enc = meshopt::encode_index_buffer(&idx, 100).unwrap();
        let out = decode(&view("TRIANGLES", idx.len(), 2, None), &enc).unwrap();
        let got: Vec<u32> = bytemuck::cast_slice::<u32, u16>(&out)[..idx.len()].iter().map(|&i| i as u32).collect();
        // The triangle codec may rotate a triangle's corners (keeping its winding).
        let canon = |t: &[u32]| (0..3).map(|r| [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]).min().unwrap();
        assert!(got.chunks(3).zip(idx.chunks(3)).all(|(a, b)| canon(a) == canon(b)));
        let enc = meshopt::encode_index_sequence(&idx, 100).unwrap();
        assert_eq!(decode(&view("INDICES", idx.len(), 4, None), &enc).unwrap(), idx);
    }

    #[test]
    fn truncated_and_mismatched_streams_are_errors() {
        let verts: Vec<[f32; 3]> = (0..64).map(|i| [i as f32, 0.5, -1.0]).collect();
        let enc = meshopt::encode_vertex_buffer(&verts).unwrap();
        for n in [0, 1, enc.len() / 2, enc.len() - 1] {
            assert!(decode(&view("ATTRIBUTES", 64, 12, None), &enc[..n]).is_err(), "prefix {n}");
        }
        assert!(decode(&view("ATTRIBUTES", 64, 10, None), &enc).unwrap_err().to_string().contains("not a valid combination"));
        assert!(decode(&view("TRIANGLES", 4, 2, None), &enc).is_err());
        assert!(decode(&view("ATTRIBUTES", 64, 12, Some("OCTAHEDRAL")), &enc).unwrap_err().to_string().contains("OCTAHEDRAL"));
        assert!(decode(&view("ATTRIBUTES", 64, 12, Some("SPIRAL")), &enc).unwrap_err().to_string().contains("SPIRAL"));
    }
}
