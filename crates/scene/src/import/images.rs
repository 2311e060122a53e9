//! Base colour texture images, read from wherever a model keeps them: a glTF buffer view, a
//! data URI or a file beside the model (an OBJ material's map_Kd). An image that cannot be read
//! (a missing file, KTX2, past the limits) leaves its surfaces in their factor, and the
//! importer names it.

use crate::texture::{Image, decode};
use std::borrow::Cow;
use std::path::Path;

/// Per image of `doc`: decoded, or why it cannot be.
pub fn of_images(doc: &gltf::Document, buffers: &[&[u8]], base: &Path) -> Vec<Result<Image, String>> {
    doc.images()
        .map(|image| {
            let name = image.name().map_or_else(|| format!("image {}", image.index()), str::to_owned);
            encoded(doc, image.index(), buffers, base).and_then(|bytes| decode(&name, &bytes))
        })
        .collect()
}

/// The image file at `path`.
pub fn of_file(path: &Path) -> Result<Image, String> {
    decode(&path.display().to_string(), &std::fs::read(path).map_err(|e| e.to_string())?)
}

/// An image's encoded bytes: a buffer view, a data URI or a file beside the model. Read from
/// the JSON: the `gltf` crate's `Image::source` panics on an image with neither, or a view
/// without a MIME type.
fn encoded<'a>(doc: &gltf::Document, k: usize, buffers: &[&'a [u8]], base: &Path) -> Result<Cow<'a, [u8]>, String> {
    let json = &doc.as_json().images[k];
    match (&json.buffer_view, &json.uri) {
        (Some(v), _) => {
            let view = doc.views().nth(v.value()).ok_or("its buffer view is missing")?;
            let buffer = buffers.get(view.buffer().index()).ok_or("its buffer is missing")?;
            let bytes = buffer.get(view.offset()..view.offset().saturating_add(view.length()));
            bytes.map(Cow::Borrowed).ok_or_else(|| "its view lies past its buffer".into())
        }
        (None, Some(uri)) => match uri.strip_prefix("data:") {
            Some(rest) => {
                let (_, data) = rest.split_once(";base64,").ok_or("a data URI that is not base64")?;
                base64::decode(data).map(Cow::Owned).map_err(|e| format!("its data URI: {e}"))
            }
            None => std::fs::read(base.join(uri)).map(Cow::Owned).map_err(|e| e.to_string()),
        },
        (None, None) => Err("neither a buffer view nor a URI".into()),
    }
}

/// Image `k`'s file name, where it is one (not a data URI or a buffer view).
pub fn file_name(doc: &gltf::Document, k: usize) -> Option<&str> {
    let uri = doc.as_json().images[k].uri.as_deref()?;
    (!uri.starts_with("data:")).then_some(uri)
}
