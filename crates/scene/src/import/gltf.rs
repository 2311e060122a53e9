//! glTF 2.0 reader (.gltf with external or embedded buffers, .glb) for models as exporters and
//! gltfpack write them: the default scene's node hierarchy with transforms composed in f64;
//! every triangle primitive (list, strip or fan; indexed or not; sparse or not) becomes part
//! of one object per mesh instance (a node, or each instance of EXT_mesh_gpu_instancing);
//! POSITION may be float or KHR_mesh_quantization's (normalized) integers; views may be
//! EXT_meshopt_compression streams. Colours are COLOR_0 times the material's factor; a BLEND
//! material's alpha makes its triangles translucent, a MASK material's discards those below
//! its cutoff and makes cut-outs of those it may hole (see [`crate::mesh::Mesh::colors`]).
//! Points and lines are skipped with a warning; Draco is
//! refused with how to re-export. A base colour texture is decoded for its mean colour alone
//! ([`super::texture_mean`]). Every accessor is checked against its buffer before it is read.
//!
//! The `gltf` crate validates `extensionsRequired` against the extensions it implements, which
//! excludes the ones above: the document is validated here in every other respect, and the
//! required extensions are checked by [`gltf_raw::Raw::check_extensions`].

use super::gltf_raw::{self, Raw};
use super::texture_mean::{self, Mean};
use super::{ImportError, Imported, ParseError, first_few};
use crate::mesh::{Mesh, Object};
use crate::normal::{NO_NORMAL, Normal};
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
    let means = texture_mean::of_images(&doc, &buffers, base);

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
            let m = mesh_of(&mesh, &buffers, &means, &mut out.skipped).map_err(|e| e.at(format!("mesh {}", mesh.index())))?;
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
    out.left_out = texture_notes(&doc, &means);
    Ok(out)
}

/// What the build leaves out of the materials' base colour textures (or the diffuse ones of
/// KHR_materials_pbrSpecularGlossiness), which it does not sample: the textures (drawn as
/// their mean colour), those it cannot read at all, and the alpha of MASK and BLEND materials
/// that comes from them (a cut-out is drawn whole and occludes nothing). Each names its first
/// few.
fn texture_notes(doc: &gltf::Document, means: &[Result<Mean, String>]) -> Vec<String> {
    let textured: Vec<(gltf::Material, gltf::Texture)> =
        doc.materials().filter_map(|m| Some((m.clone(), base_texture(&m)?.texture()))).collect();
    let textures: std::collections::BTreeSet<usize> = textured.iter().map(|(_, t)| t.index()).collect();
    let alpha: Vec<String> = textured.iter().filter(|(m, _)| m.alpha_mode() != AlphaMode::Opaque).map(|(m, _)| material_name(m)).collect();
    let mut notes = Vec::new();
    if !textures.is_empty() {
        let names: Vec<String> = textures.iter().filter_map(|&k| doc.textures().nth(k)).map(|t| texture_name(&t)).collect();
        notes.push(format!(
            "{} base colour textures of {} materials (textures are not sampled: those surfaces are drawn in their factor and COLOR_0 times the texture's mean colour): {}",
            textures.len(),
            textured.len(),
            first_few(&names)
        ));
        let unread: Vec<String> = textures
            .iter()
            .filter_map(|&k| doc.textures().nth(k))
            .filter_map(|t| Some(format!("{} ({})", texture_name(&t), means.get(t.source().index())?.as_ref().err()?)))
            .collect();
        if !unread.is_empty() {
            notes.push(format!(
                "{} base colour textures that cannot be read (drawn in their factor): {}",
                unread.len(),
                first_few(&unread)
            ));
        }
    }
    if !alpha.is_empty() {
        notes.push(format!(
            "the texture alpha of {} MASK or BLEND materials (a MASK one is drawn opaque and occludes nothing, a BLEND one blends by its factor and COLOR_0): {}",
            alpha.len(),
            first_few(&alpha)
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
fn texture_name(t: &gltf::Texture) -> String {
    let image = t.source();
    let file = match image.source() {
        gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => Some(uri),
        _ => None,
    };
    t.name().or(image.name()).or(file).map_or_else(|| format!("texture {}", t.index()), |n| format!("'{n}'"))
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
fn mesh_of(mesh: &gltf::Mesh, buffers: &[&[u8]], means: &[Result<Mean, String>], skipped: &mut Vec<String>) -> Result<Mesh, ParseError> {
    let mut m = Mesh::default();
    for prim in mesh.primitives() {
        if matches!(prim.mode(), Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
            skipped.push(format!("mesh {} primitive {}: mode {:?} has no triangles", mesh.index(), prim.index(), prim.mode()));
            continue;
        }
        let (p, notes) = primitive(&prim, buffers, means).map_err(|e| e.at(format!("primitive {}", prim.index())))?;
        skipped.extend(notes.into_iter().map(|n| format!("mesh {} primitive {}: {n}", mesh.index(), prim.index())));
        m.append(&p);
    }
    Ok(m)
}

/// A primitive's triangles and colours, and what of its material was left out.
fn primitive(prim: &gltf::Primitive, buffers: &[&[u8]], means: &[Result<Mean, String>]) -> Result<(Mesh, Vec<String>), ParseError> {
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
    let Some(rgba) = colors(prim, buffers, means, positions.len())? else {
        return Ok((Mesh { positions, indices, normals, single_sided, ..Mesh::default() }, notes));
    };
    let name = || material_name(&material);
    let encode = |c: [f32; 4], a: u8| [srgb8(c[0]), srgb8(c[1]), srgb8(c[2]), a];
    let colors = match material.alpha_mode() {
        AlphaMode::Opaque => rgba.iter().map(|&c| encode(c, 255)).collect(),
        AlphaMode::Blend => rgba.iter().map(|&c| encode(c, crate::mesh::alpha(c[3]))).collect(),
        // Alpha testing (glTF 2.0 sec. 3.9.4) without textures: a triangle whose alpha is below
        // the cutoff at every corner is discarded whole, the rest drawn opaque. Those holed
        // where their alpha falls below the cutoff, between corners or by their texture's alpha
        // (not read), are cut-outs: never occluders.
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
    Ok((Mesh { positions, indices, colors, normals, single_sided }, notes))
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
/// (glTF 2.0 sec. 3.9.2) times its base colour texture's mean where that can be read (of a
/// MASK material the colour alone: its alpha is tested against the cutoff). None for a
/// primitive with neither a material nor COLOR_0 (glTF's default material is plain white,
/// which would hide the objects from each other).
fn colors(
    prim: &gltf::Primitive,
    buffers: &[&[u8]],
    means: &[Result<Mean, String>],
    vertices: usize,
) -> Result<Option<Vec<[f32; 4]>>, ParseError> {
    let material = prim.material();
    let color0 = prim.get(&gltf::Semantic::Colors(0));
    if material.index().is_none() && color0.is_none() {
        return Ok(None);
    }
    let mut base = material.pbr_metallic_roughness().base_color_factor();
    let mean = base_texture(&material).and_then(|t| means.get(t.texture().source().index())?.as_ref().ok().copied());
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

/// A linear colour channel as an sRGB byte.
fn srgb8(linear: f32) -> u8 {
    (texture_mean::linear_to_srgb(linear) * 255.0).round() as u8
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
