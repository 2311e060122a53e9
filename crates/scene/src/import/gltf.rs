//! glTF 2.0 reader (.gltf with external or embedded buffers, .glb) for models as exporters and
//! gltfpack write them: the default scene's node hierarchy with transforms composed in f64;
//! every triangle primitive (list, strip or fan; indexed or not; sparse or not) becomes part
//! of one object per mesh instance (a node, or each instance of EXT_mesh_gpu_instancing);
//! POSITION may be float or KHR_mesh_quantization's (normalized) integers; views may be
//! EXT_meshopt_compression streams. Colours are COLOR_0 times the material's factor; a BLEND
//! material's alpha makes its triangles translucent, a MASK material's discards those below
//! its cutoff and makes cut-outs of those it may hole (see [`crate::mesh::Mesh::colors`]).
//! Points and lines are skipped with a warning; Draco is
//! refused with how to re-export. A base colour texture (PNG or JPEG: embedded, a data URI or
//! a file beside the model) is decoded and stored with its sampler, and sampled at the
//! primitive's texture coordinates (`KHR_texture_transform` applied here); a primitive without
//! them is drawn in the texture's mean colour. Every accessor is checked against its buffer
//! before it is read.
//!
//! The `gltf` crate validates `extensionsRequired` against the extensions it implements, which
//! excludes the ones above: the document is validated here in every other respect, and the
//! required extensions are checked by [`gltf_raw::Raw::check_extensions`].

use super::gltf_raw::{self, Raw};
use super::{ImportError, Imported, ParseError, first_few};
use crate::mesh::{Mesh, Object};
use crate::normal::{NO_NORMAL, Normal};
use crate::texture::{Filter, Image, Sampler, Texcoord, Texture, Textures, Wrap, srgb8};
use glam::{DAffine3, DMat4, DQuat, DVec3, Vec3};
use gltf::accessor::{Accessor, DataType, Dimensions, Item};
use gltf::material::AlphaMode;
use gltf::mesh::Mode;
use std::path::Path;

/// Reads the glTF or GLB file at `path`, loading its buffers (files beside it or data URIs).
pub fn read(path: &Path) -> Result<Imported, ImportError> {
    let bytes = std::fs::read(path).map_err(ImportError::io(path))?;
    parse(&bytes, path.parent().unwrap_or(Path::new("."))).map_err(ImportError::malformed(path))
}

/// Parses glTF or GLB bytes whose external buffers lie in `base`. Errors say what is wrong.
pub fn parse(bytes: &[u8], base: &Path) -> Result<Imported, ParseError> {
    let (json, blob) = if bytes.starts_with(b"glTF") {
        let glb = gltf::binary::Glb::from_slice(bytes).map_err(|e| ParseError::caused("not a valid GLB", e))?;
        (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes.to_vec(), None)
    };
    let root: gltf::json::Root = gltf::json::deserialize::from_slice(&json).map_err(|e| ParseError::caused("not valid glTF", e))?;
    let raw: Raw = serde_json::from_slice(&json).map_err(|e| ParseError::caused("not valid glTF", e))?;
    raw.check_extensions()?;
    raw.check_attributes()?;
    validate(&root)?;
    let doc = gltf::Document::from_json_without_validation(root);
    let buffers = load_buffers(&doc, &raw, base, blob)?;
    let buffers: Vec<&[u8]> = buffers.iter().map(Vec::as_slice).collect();
    let mut table = TextureTable::new(super::images::of_images(&doc, &buffers, base));

    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => doc.nodes().filter(|n| !doc.nodes().any(|p| p.children().any(|c| c.index() == n.index()))).collect(),
    };
    let mut out = Imported::default();
    // Each node's world transform as whole units (the anchor) after the rest: the whole units
    // are taken out at every node, so that a model under a parent translated far away is
    // composed at its own scale, as at the origin (see crate::place).
    let mut stack: Vec<(gltf::Node, DVec3, DMat4, usize)> = roots.into_iter().map(|n| (n, DVec3::ZERO, DMat4::IDENTITY, 0)).collect();
    while let Some((node, anchor, parent, depth)) = stack.pop() {
        if depth > 256 {
            return Err(ParseError::new("node hierarchy deeper than 256 (a cycle?)"));
        }
        let raw_node = raw.nodes.get(node.index()).ok_or_else(|| ParseError::new("node table unreadable"))?;
        let (whole, world) = crate::place::split(parent * raw_node.local());
        let anchor = anchor + whole;
        if !world.is_finite() || !anchor.is_finite() {
            return Err(ParseError::new(format!("node {} has a non-finite transform", node.index())));
        }
        if let Some(mesh) = node.mesh() {
            let m = mesh_of(&mesh, &buffers, &mut table, &mut out.skipped).map_err(|e| e.at(format!("mesh {}", mesh.index())))?;
            let name = node.name().or(mesh.name()).map(str::to_owned).unwrap_or_else(|| format!("node {}", node.index()));
            let prototype = Some(mesh.index() as u32);
            match &raw_node.extensions.instancing {
                None => out.objects.push(Object { prototype, ..Object::placed(name, m, anchor, DAffine3::from_mat4(world)) }),
                Some(inst) => {
                    let at = |e: ParseError| e.at(format!("node {} EXT_mesh_gpu_instancing", node.index()));
                    for (k, t) in instances(inst, &doc, &buffers).map_err(at)?.into_iter().enumerate() {
                        let (whole, placement) = crate::place::split(world * t);
                        if !placement.is_finite() || !whole.is_finite() {
                            return Err(at(ParseError::new(format!("instance {k} has a non-finite transform"))));
                        }
                        let placement = DAffine3::from_mat4(placement);
                        let o = Object::placed(format!("{name} instance {k}"), m.clone(), anchor + whole, placement);
                        out.objects.push(Object { prototype, ..o });
                    }
                }
            }
        }
        stack.extend(node.children().map(|c| (c, anchor, world, depth + 1)));
    }
    // A mesh's notes once, however many nodes use it.
    let mut seen = std::collections::HashSet::new();
    out.skipped.retain(|s| seen.insert(s.clone()));
    out.left_out = texture_notes(&doc, &table);
    out.textures = table.stored;
    Ok(out)
}

/// The model's images, decoded once, and the textures its primitives sample, stored once.
struct TextureTable {
    /// Per image of the document: decoded (taken once stored), or why it cannot be.
    images: Vec<Result<Image, String>>,
    /// Per image of the document: its linear mean, where it can be read.
    means: Vec<Option<[f32; 4]>>,
    /// Per image of the document: its index in `stored`, once a primitive samples it.
    at: Vec<Option<u32>>,
    stored: Textures,
}

impl TextureTable {
    fn new(images: Vec<Result<Image, String>>) -> TextureTable {
        let means = images.iter().map(|i| i.as_ref().ok().map(crate::texture::mean)).collect();
        TextureTable { at: vec![None; images.len()], images, means, stored: Textures::default() }
    }

    fn mean(&self, info: &gltf::texture::Info) -> Option<[f32; 4]> {
        self.means.get(info.texture().source().index()).copied().flatten()
    }

    /// The texture `info` names, sampled under `material`, stored on first use; None where its
    /// image cannot be read.
    fn texture(&mut self, info: &gltf::texture::Info, material: &gltf::Material) -> Option<u32> {
        let k = info.texture().source().index();
        let image = match self.at.get(k).copied().flatten() {
            Some(image) => image,
            None => {
                let decoded = std::mem::take(self.images.get_mut(k)?.as_mut().ok()?);
                self.stored.images.push(decoded);
                self.at[k] = Some(self.stored.images.len() as u32 - 1);
                self.stored.images.len() as u32 - 1
            }
        };
        // glTF 2.0 sec. 3.9.4: alpha is the factor times COLOR_0 times the texel against the cutoff; the
        // factor is folded into the cutoff (COLOR_0's alpha is tested per triangle, above).
        let factor = material.pbr_metallic_roughness().base_color_factor()[3];
        let cutoff = (material.alpha_mode() == AlphaMode::Mask).then(|| material.alpha_cutoff().unwrap_or(0.5) / factor.max(1e-6));
        Some(self.stored.add(Texture { image, sampler: sampler_of(&info.texture().sampler()), cutoff }))
    }

    fn unread(&self, k: usize) -> Option<&str> {
        self.images.get(k)?.as_ref().err().map(String::as_str)
    }
}

/// A glTF sampler as osw's: wrap modes, and the filters (glTF 2.0 sec. 3.8.4; without filters,
/// trilinear).
fn sampler_of(s: &gltf::texture::Sampler) -> Sampler {
    use gltf::texture::{MagFilter, MinFilter, WrappingMode};
    let wrap = |w: WrappingMode| match w {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::ClampToEdge => Wrap::Clamp,
        WrappingMode::MirroredRepeat => Wrap::Mirror,
    };
    let mag = match s.mag_filter() {
        Some(MagFilter::Nearest) => Filter::Nearest,
        _ => Filter::Linear,
    };
    let (min, mip) = match s.min_filter() {
        Some(MinFilter::Nearest) => (Filter::Nearest, None),
        Some(MinFilter::Linear) => (Filter::Linear, None),
        Some(MinFilter::NearestMipmapNearest) => (Filter::Nearest, Some(Filter::Nearest)),
        Some(MinFilter::LinearMipmapNearest) => (Filter::Linear, Some(Filter::Nearest)),
        Some(MinFilter::NearestMipmapLinear) => (Filter::Nearest, Some(Filter::Linear)),
        Some(MinFilter::LinearMipmapLinear) | None => (Filter::Linear, Some(Filter::Linear)),
    };
    Sampler { wrap: [wrap(s.wrap_s()), wrap(s.wrap_t())], mag, min, mip }
}

/// What the build leaves out of the materials' textures: base colour textures it cannot read
/// (drawn in their factor) or that a primitive samples without texture coordinates (drawn in
/// their mean colour), and the other textures of a material, which osw does not draw (normal,
/// occlusion, emissive, metallic-roughness). Each names its first few.
fn texture_notes(doc: &gltf::Document, table: &TextureTable) -> Vec<String> {
    let base: std::collections::BTreeSet<usize> = doc.materials().filter_map(|m| Some(base_texture(&m)?.texture().index())).collect();
    let mut notes = Vec::new();
    let unread: Vec<String> = base
        .iter()
        .filter_map(|&k| doc.textures().nth(k))
        .filter_map(|t| Some(format!("{} ({})", texture_name(doc, &t), table.unread(t.source().index())?)))
        .collect();
    if !unread.is_empty() {
        notes.push(format!("{} base colour textures that cannot be read (drawn in their factor): {}", unread.len(), first_few(&unread)));
    }
    let other: std::collections::BTreeSet<usize> = doc
        .materials()
        .flat_map(|m| {
            let pbr = m.pbr_metallic_roughness();
            [
                m.normal_texture().map(|t| t.texture().index()),
                m.occlusion_texture().map(|t| t.texture().index()),
                m.emissive_texture().map(|t| t.texture().index()),
                pbr.metallic_roughness_texture().map(|t| t.texture().index()),
            ]
        })
        .flatten()
        .filter(|k| !base.contains(k))
        .collect();
    if !other.is_empty() {
        let names: Vec<String> = other.iter().filter_map(|&k| doc.textures().nth(k)).map(|t| texture_name(doc, &t)).collect();
        notes.push(format!(
            "{} normal, occlusion, emissive or metallic-roughness textures (osw draws the base colour and its own light): {}",
            other.len(),
            first_few(&names)
        ));
    }
    notes
}

/// A material's base colour texture, or the diffuse one of KHR_materials_pbrSpecularGlossiness.
fn base_texture<'a>(m: &gltf::Material<'a>) -> Option<gltf::texture::Info<'a>> {
    m.pbr_metallic_roughness().base_color_texture().or_else(|| m.pbr_specular_glossiness()?.diffuse_texture())
}

fn material_name(m: &gltf::Material) -> String {
    m.name().map_or_else(|| format!("material {}", m.index().map_or("default".into(), |k| k.to_string())), |n| format!("'{n}'"))
}

/// A texture's name, else its image's name or file, else its index.
fn texture_name(doc: &gltf::Document, t: &gltf::Texture) -> String {
    let image = t.source();
    t.name()
        .or(image.name())
        .or(super::images::file_name(doc, image.index()))
        .map_or_else(|| format!("texture {}", t.index()), |n| format!("'{n}'"))
}

/// The `gltf` crate's validation (indices in range, so that its accessors cannot panic),
/// without its check of `extensionsRequired`.
fn validate(root: &gltf::json::Root) -> Result<(), ParseError> {
    use gltf::json::validation::Validate;
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, e| {
        let path = path().to_string();
        if !path.starts_with("extensionsRequired") {
            errors.push(format!("{path}: {e}"));
        }
    });
    match errors.as_slice() {
        [] => Ok(()),
        [first, ..] => Err(ParseError::new(format!("not valid glTF: {first} ({} problems)", errors.len()))),
    }
}

/// Every buffer's bytes; EXT_meshopt_compression fallback buffers (no data of their own) are
/// made as large as the views decoded into them, then filled by decoding.
fn load_buffers(doc: &gltf::Document, raw: &Raw, base: &Path, mut blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>, ParseError> {
    let fallback = super::meshopt_views::fallback_sizes(doc, raw);
    let mut buffers = Vec::with_capacity(doc.buffers().len());
    for b in doc.buffers() {
        let is_fallback = raw.buffers.get(b.index()).and_then(|r| r.extensions.meshopt.as_ref()).is_some_and(|m| m.fallback);
        let data = if is_fallback {
            if fallback[b.index()] > b.length() {
                return Err(ParseError::new(format!(
                    "buffer {}: compressed views decode to {} bytes, past its length {}",
                    b.index(),
                    fallback[b.index()],
                    b.length()
                )));
            }
            vec![0u8; fallback[b.index()]]
        } else {
            let d = gltf::buffer::Data::from_source_and_blob(b.source(), Some(base), &mut blob)
                .map_err(|e| ParseError::caused(format!("cannot load a buffer (buffer {})", b.index()), e))?;
            if d.len() < b.length() {
                let (at, len, declared) = (b.index(), d.len(), b.length());
                return Err(ParseError::new(format!("buffer {at} has {len} bytes, {declared} declared (file truncated?)")));
            }
            d.0
        };
        buffers.push(data);
    }
    super::meshopt_views::decode_views(doc, raw, &mut buffers)?;
    Ok(buffers)
}

/// The triangles of every primitive of `mesh`, in the mesh's frame.
fn mesh_of(mesh: &gltf::Mesh, buffers: &[&[u8]], table: &mut TextureTable, skipped: &mut Vec<String>) -> Result<Mesh, ParseError> {
    let mut m = Mesh::default();
    for prim in mesh.primitives() {
        if matches!(prim.mode(), Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
            skipped.push(format!("mesh {} primitive {}: mode {:?} has no triangles", mesh.index(), prim.index(), prim.mode()));
            continue;
        }
        let (p, notes) = primitive(&prim, buffers, table).map_err(|e| e.at(format!("primitive {}", prim.index())))?;
        skipped.extend(notes.into_iter().map(|n| format!("mesh {} primitive {}: {n}", mesh.index(), prim.index())));
        m.append(&p);
    }
    Ok(m)
}

/// A primitive's triangles and colours, and what of its material was left out.
fn primitive(prim: &gltf::Primitive, buffers: &[&[u8]], table: &mut TextureTable) -> Result<(Mesh, Vec<String>), ParseError> {
    let pos = prim.get(&gltf::Semantic::Positions).ok_or_else(|| ParseError::new("no POSITION attribute"))?;
    if pos.dimensions() != Dimensions::Vec3 {
        return Err(ParseError::new(format!("POSITION is {:?}, expected VEC3", pos.dimensions())));
    }
    let positions: Vec<[f32; 3]> = floats(&pos, buffers).map_err(|e| e.at("POSITION"))?;
    let order: Vec<u32> = match prim.indices() {
        Some(idx) => {
            check(&idx, buffers)?;
            let reader = prim.reader(|b| buffers.get(b.index()).copied());
            reader.read_indices().ok_or_else(|| ParseError::new("index data missing"))?.into_u32().collect()
        }
        None => (0..positions.len() as u32).collect(),
    };
    // Checked per primitive: once merged, an index past this primitive's vertices would name a
    // vertex of the next.
    if let Some((at, &index)) = order.iter().enumerate().find(|&(_, &i)| i as usize >= positions.len()) {
        return Err(ParseError::new(format!(
            "index {index} at position {at} is out of range (the primitive has {} vertices)",
            positions.len()
        )));
    }
    let mut indices = triangle_list(prim.mode(), &order);
    let mut notes = Vec::new();
    let normals = normals(prim, buffers, positions.len(), &mut notes)?;
    let material = prim.material();
    // Back faces culled unless doubleSided (glTF 2.0 sec. 3.9.5; also without a material).
    let single_sided = if material.double_sided() { Vec::new() } else { vec![true; positions.len()] };
    let texcoords = sampled(prim, &material, buffers, table, positions.len(), &mut notes)?;
    let mean = if texcoords.is_empty() { base_texture(&material).and_then(|info| table.mean(&info)) } else { None };
    let Some(rgba) = colors(prim, buffers, mean, positions.len())? else {
        return Ok((Mesh { positions, indices, normals, single_sided, texcoords, ..Mesh::default() }, notes));
    };
    let name = || material_name(&material);
    let encode = |c: [f32; 4], a: u8| [srgb8(c[0]), srgb8(c[1]), srgb8(c[2]), a];
    let colors = match material.alpha_mode() {
        AlphaMode::Opaque => rgba.iter().map(|&c| encode(c, 255)).collect(),
        AlphaMode::Blend => rgba.iter().map(|&c| encode(c, crate::mesh::alpha(c[3]))).collect(),
        // Alpha testing (glTF 2.0 sec. 3.9.4) by the factor and COLOR_0: a triangle whose alpha
        // is below the cutoff at every corner is discarded whole, the rest drawn opaque. Those
        // holed where their alpha falls below the cutoff, between corners or by their texture's
        // alpha (tested per pixel where sampled), are cut-outs: never occluders.
        AlphaMode::Mask => {
            let cutoff = material.alpha_cutoff().unwrap_or(0.5);
            let before = indices.len() / 3;
            indices = indices.chunks_exact(3).filter(|t| t.iter().any(|&v| rgba[v as usize][3] >= cutoff)).flatten().copied().collect();
            if indices.len() / 3 < before {
                notes.push(format!("{} triangles below material {}'s alpha cutoff {cutoff} (MASK)", before - indices.len() / 3, name()));
            }
            let textured = base_texture(&material).is_some();
            let mut colors: Vec<[u8; 4]> = rgba.iter().map(|&c| encode(c, 255)).collect();
            for t in indices.chunks_exact(3).filter(|t| textured || t.iter().any(|&v| rgba[v as usize][3] < cutoff)) {
                t.iter().for_each(|&v| colors[v as usize][3] = crate::mesh::CUT_OUT);
            }
            colors
        }
    };
    Ok((Mesh { positions, indices, colors, normals, single_sided, texcoords }, notes))
}

/// Where each vertex samples the material's base colour texture; empty where the material
/// has none, its image cannot be read or the primitive has no coordinates for it.
fn sampled(
    prim: &gltf::Primitive,
    material: &gltf::Material,
    buffers: &[&[u8]],
    table: &mut TextureTable,
    vertices: usize,
    notes: &mut Vec<String>,
) -> Result<Vec<Texcoord>, ParseError> {
    let Some(info) = base_texture(material).filter(|info| table.mean(info).is_some()) else { return Ok(Vec::new()) };
    let Some(uv) = texcoords(prim, &info, buffers, vertices, notes)? else { return Ok(Vec::new()) };
    let Some(texture) = table.texture(&info, material) else { return Ok(Vec::new()) };
    Ok(uv.into_iter().map(|uv| Texcoord { uv, texture }).collect())
}

/// The coordinates at which a primitive samples the texture of `info`: its TEXCOORD_n,
/// through `KHR_texture_transform` (offset, rotation and scale: T x R x S, as the extension
/// defines it). None where the primitive has no such set.
fn texcoords(
    prim: &gltf::Primitive,
    info: &gltf::texture::Info,
    buffers: &[&[u8]],
    vertices: usize,
    notes: &mut Vec<String>,
) -> Result<Option<Vec<[f32; 2]>>, ParseError> {
    let transform = info.texture_transform();
    let set = transform.as_ref().and_then(|t| t.tex_coord()).unwrap_or(info.tex_coord());
    let Some(acc) = prim.get(&gltf::Semantic::TexCoords(set)) else {
        notes.push(format!("no TEXCOORD_{set} for its base colour texture (drawn in the texture's mean colour)"));
        return Ok(None);
    };
    if acc.dimensions() != Dimensions::Vec2 {
        return Err(ParseError::new(format!("TEXCOORD_{set} is {:?}, expected VEC2", acc.dimensions())));
    }
    let mut uv = floats::<2>(&acc, buffers).map_err(|e| e.at(format!("TEXCOORD_{set}")))?;
    if uv.len() != vertices {
        return Err(ParseError::new(format!("TEXCOORD_{set} has {} elements for {vertices} vertices", uv.len())));
    }
    if let Some(t) = transform {
        let ([x, y], r, [sx, sy]) = (t.offset(), t.rotation(), t.scale());
        let (sin, cos) = r.sin_cos();
        for p in &mut uv {
            let [u, v] = *p;
            *p = [cos * sx * u + sin * sy * v + x, -sin * sx * u + cos * sy * v + y];
        }
    }
    let bad = uv.iter().filter(|p| !p.iter().all(|c| c.is_finite())).count();
    if bad > 0 {
        uv.iter_mut().filter(|p| !p.iter().all(|c| c.is_finite())).for_each(|p| *p = [0.0; 2]);
        notes.push(format!("{bad} texture coordinates not finite (sampled at 0, 0)"));
    }
    Ok(Some(uv))
}

/// The primitive's NORMAL, encoded; empty without one. A normal of zero length or not finite
/// is left for the build to compute, and counted in `notes`.
fn normals(prim: &gltf::Primitive, buffers: &[&[u8]], vertices: usize, notes: &mut Vec<String>) -> Result<Vec<Normal>, ParseError> {
    let Some(acc) = prim.get(&gltf::Semantic::Normals) else { return Ok(Vec::new()) };
    if acc.dimensions() != Dimensions::Vec3 {
        return Err(ParseError::new(format!("NORMAL is {:?}, expected VEC3", acc.dimensions())));
    }
    let given = floats::<3>(&acc, buffers).map_err(|e| e.at("NORMAL"))?;
    if given.len() != vertices {
        return Err(ParseError::new(format!("NORMAL has {} elements for {vertices} vertices", given.len())));
    }
    let normals: Vec<Normal> = given.into_iter().map(|n| crate::normal::given(Vec3::from_array(n))).collect();
    let bad = normals.iter().filter(|&&n| n == NO_NORMAL).count();
    if bad > 0 {
        notes.push(format!("{bad} normals of zero length or not finite (computed instead)"));
    }
    Ok(normals)
}

/// The primitive's linear colour per vertex: COLOR_0 times the material's baseColorFactor
/// (glTF 2.0 sec. 3.9.2), times `mean`, its base colour texture's mean where that is read but
/// not sampled (of a MASK material the colour alone: its alpha is tested against the cutoff).
/// None for a primitive with neither a material nor COLOR_0 (glTF's default material is plain
/// white, which would hide the objects from each other).
fn colors(prim: &gltf::Primitive, buffers: &[&[u8]], mean: Option<[f32; 4]>, vertices: usize) -> Result<Option<Vec<[f32; 4]>>, ParseError> {
    let material = prim.material();
    let color0 = prim.get(&gltf::Semantic::Colors(0));
    if material.index().is_none() && color0.is_none() {
        return Ok(None);
    }
    let mut base = material.pbr_metallic_roughness().base_color_factor();
    if let Some(mean) = mean {
        let channels = if material.alpha_mode() == AlphaMode::Mask { 3 } else { 4 };
        (0..channels).for_each(|k| base[k] *= mean[k]);
    }
    let per_vertex: Vec<[f32; 4]> = match color0 {
        None => vec![[1.0; 4]; vertices],
        Some(acc) => {
            let rgba = match acc.dimensions() {
                Dimensions::Vec3 => floats::<3>(&acc, buffers).map(|v| v.into_iter().map(|[r, g, b]| [r, g, b, 1.0]).collect()),
                Dimensions::Vec4 => floats::<4>(&acc, buffers),
                d => return Err(ParseError::new(format!("COLOR_0 is {d:?}, expected VEC3 or VEC4"))),
            }
            .map_err(|e| e.at("COLOR_0"))?;
            if rgba.len() != vertices {
                return Err(ParseError::new(format!("COLOR_0 has {} elements for {vertices} vertices", rgba.len())));
            }
            rgba
        }
    };
    Ok(Some(per_vertex.into_iter().map(|c| [0, 1, 2, 3].map(|k| c[k] * base[k])).collect()))
}

/// A triangle list from the vertex order of a list, strip or fan (glTF 2.0 sec. 3.7.2.1).
fn triangle_list(mode: Mode, v: &[u32]) -> Vec<u32> {
    let n = v.len();
    match mode {
        Mode::TriangleStrip => (0..n.saturating_sub(2)).flat_map(|i| [v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]]).collect(),
        Mode::TriangleFan => (0..n.saturating_sub(2)).flat_map(|i| [v[i + 1], v[i + 2], v[0]]).collect(),
        _ => v[..n - n % 3].to_vec(),
    }
}

/// The per-instance transforms of EXT_mesh_gpu_instancing (T · R · S each).
fn instances(inst: &gltf_raw::Instancing, doc: &gltf::Document, buffers: &[&[u8]]) -> Result<Vec<DMat4>, ParseError> {
    let accessor = |name: &str| -> Result<Option<Accessor>, ParseError> {
        let missing = |i: usize| ParseError::new(format!("{name} accessor {i} does not exist"));
        inst.attributes.get(name).map(|&i| doc.accessors().nth(i).ok_or_else(|| missing(i))).transpose()
    };
    let vec3s = |name: &str| -> Result<Option<Vec<[f32; 3]>>, ParseError> {
        accessor(name)?.map(|a| floats::<3>(&a, buffers).map_err(|e| e.at(name))).transpose()
    };
    let (t, s) = (vec3s("TRANSLATION")?, vec3s("SCALE")?);
    let r = accessor("ROTATION")?.map(|a| floats::<4>(&a, buffers).map_err(|e| e.at("ROTATION"))).transpose()?;
    let counts: Vec<usize> = [t.as_ref().map(Vec::len), r.as_ref().map(Vec::len), s.as_ref().map(Vec::len)].into_iter().flatten().collect();
    let count = *counts.first().ok_or_else(|| ParseError::new("no TRANSLATION, ROTATION or SCALE attribute"))?;
    if counts.iter().any(|&c| c != count) {
        return Err(ParseError::new(format!("attribute counts differ: {counts:?}")));
    }
    let d3 = |v: &Option<Vec<[f32; 3]>>, k: usize, or: DVec3| v.as_ref().map_or(or, |v| Vec3::from_array(v[k]).as_dvec3());
    Ok((0..count)
        .map(|k| {
            let q = r.as_ref().map_or(DQuat::IDENTITY, |r| DQuat::from_array(r[k].map(f64::from)).normalize());
            DMat4::from_scale_rotation_translation(d3(&s, k, DVec3::ONE), q, d3(&t, k, DVec3::ZERO))
        })
        .collect())
}

/// A float or integer accessor of N components as f32: normalized integers mapped to [-1, 1]
/// or [0, 1] as glTF 2.0 sec. 3.11 defines, others as their values (KHR_mesh_quantization's
/// positions: the node transform dequantizes them, in f64).
fn floats<const N: usize>(acc: &Accessor, buffers: &[&[u8]]) -> Result<Vec<[f32; N]>, ParseError>
where
    [f32; N]: Item,
    [i8; N]: Item,
    [u8; N]: Item,
    [i16; N]: Item,
    [u16; N]: Item,
    [u32; N]: Item,
{
    check(acc, buffers)?;
    if acc.count() == 0 {
        return Ok(Vec::new());
    }
    let norm = acc.normalized();
    let scale = |c: f32, max: f32| if norm { (c / max).max(-1.0) } else { c };
    Ok(match acc.data_type() {
        DataType::F32 => items::<[f32; N]>(acc, buffers)?,
        DataType::I8 => items::<[i8; N]>(acc, buffers)?.into_iter().map(|v| v.map(|c| scale(c as f32, 127.0))).collect(),
        DataType::U8 => items::<[u8; N]>(acc, buffers)?.into_iter().map(|v| v.map(|c| scale(c as f32, 255.0))).collect(),
        DataType::I16 => items::<[i16; N]>(acc, buffers)?.into_iter().map(|v| v.map(|c| scale(c as f32, 32767.0))).collect(),
        DataType::U16 => items::<[u16; N]>(acc, buffers)?.into_iter().map(|v| v.map(|c| scale(c as f32, 65535.0))).collect(),
        DataType::U32 if !norm => items::<[u32; N]>(acc, buffers)?.into_iter().map(|v| v.map(|c| c as f32)).collect(),
        t => return Err(ParseError::new(format!("component type {t:?}{} is not allowed here", if norm { " normalized" } else { "" }))),
    })
}

/// An accessor's elements, sparse substitution applied by the `gltf` crate.
fn items<T: Item + Copy>(acc: &Accessor, buffers: &[&[u8]]) -> Result<Vec<T>, ParseError> {
    let iter = gltf::accessor::Iter::<T>::new(acc.clone(), |b| buffers.get(b.index()).copied());
    let v: Vec<T> = iter.ok_or_else(|| ParseError::new(format!("accessor {} data missing", acc.index())))?.collect();
    if v.len() != acc.count() {
        return Err(ParseError::new(format!("accessor {} has {} of {} elements", acc.index(), v.len(), acc.count())));
    }
    Ok(v)
}

/// Checks that `acc` (and its sparse indices and values) lies inside its buffer view and the
/// view inside its buffer, so that reading it cannot go out of bounds.
fn check(acc: &Accessor, buffers: &[&[u8]]) -> Result<(), ParseError> {
    let elem = acc.size();
    match (acc.view(), acc.sparse()) {
        (None, None) => return Err(ParseError::new(format!("accessor {} has no buffer view", acc.index()))),
        (Some(view), _) => in_view(acc.index(), &view, acc.offset(), acc.count(), elem, buffers)?,
        (None, Some(_)) => {}
    }
    if let Some(sp) = acc.sparse() {
        if sp.count() == 0 || sp.count() > acc.count() {
            return Err(ParseError::new(format!("accessor {}: sparse count {} outside 1..={}", acc.index(), sp.count(), acc.count())));
        }
        let (i, v) = (sp.indices(), sp.values());
        in_view(acc.index(), &i.view(), i.offset(), sp.count(), i.index_type().size(), buffers)?;
        in_view(acc.index(), &v.view(), v.offset(), sp.count(), elem, buffers)?;
    }
    Ok(())
}

fn in_view(acc: usize, view: &gltf::buffer::View, offset: usize, count: usize, elem: usize, buffers: &[&[u8]]) -> Result<(), ParseError> {
    let len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
    let stride = view.stride().unwrap_or(elem).max(elem);
    let view_end = view.offset().checked_add(view.length());
    let need = match count {
        0 => Some(0),
        n => (n - 1).checked_mul(stride).and_then(|x| x.checked_add(offset)).and_then(|x| x.checked_add(elem)),
    };
    if view_end.is_none_or(|e| e > len) || need.is_none_or(|n| n > view.length()) {
        let buffer = view.buffer().index();
        return Err(ParseError::new(format!("accessor {acc} reaches past the end of its buffer (buffer {buffer} has {len} bytes)")));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_become_lists_with_the_spec_winding() {
        let v = [10, 11, 12, 13, 14];
        assert_eq!(triangle_list(Mode::TriangleStrip, &v), vec![10, 11, 12, 11, 13, 12, 12, 13, 14]);
        assert_eq!(triangle_list(Mode::TriangleFan, &v), vec![11, 12, 10, 12, 13, 10, 13, 14, 10]);
        assert_eq!(triangle_list(Mode::Triangles, &v), vec![10, 11, 12]);
        assert!(triangle_list(Mode::TriangleStrip, &v[..2]).is_empty());
    }

    #[test]
    fn linear_colours_are_encoded_as_srgb() {
        assert_eq!([0.0, 0.5, 1.0, 2.0, -1.0].map(srgb8), [0, 188, 255, 255, 0]);
    }
}
