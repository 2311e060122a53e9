//! Wavefront OBJ reader (through `tobj`, positions in f64): every object (`o`) and group (`g`)
//! becomes an object, polygons are fanned into triangles, negative (relative) indices are
//! resolved; points and lines are skipped. The material libraries it names (`mtllib`, beside
//! the file) must be readable; an object's material gives its colour (Kd) and, with d below 1,
//! its translucency; one with an alpha texture (map_d) is a cut-out ([`crate::mesh::CUT_OUT`]).
//! A diffuse texture (map_Kd) is sampled at the vertices' `vt` (OBJ's v runs up the image,
//! glTF's down), with its own alpha as a cut-out's where map_d names the same file; a
//! textured object without `vt` is drawn in Kd times the texture's mean colour. All objects of
//! a file share one f32 anchor (see [`crate::place`]).

use super::{ImportError, Imported, ParseError, first_few};
use crate::mesh::{Mesh, Object};
use crate::texture::{Sampler, Texcoord, Texture, Textures};
use glam::{DAffine3, DVec3};
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// Reads the OBJ file at `path` and the material libraries it names.
pub fn read(path: &Path) -> Result<Imported, ImportError> {
    let file = std::fs::File::open(path).map_err(ImportError::io(path))?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse(&mut std::io::BufReader::new(file), base).map_err(ImportError::malformed(path))
}

/// Parses OBJ text whose material libraries lie in `base`. Errors say what is wrong.
pub fn parse(obj: &mut impl std::io::BufRead, base: &Path) -> Result<Imported, ParseError> {
    let failed_mtl: RefCell<Option<(PathBuf, Box<dyn std::error::Error + Send + Sync>)>> = RefCell::new(None);
    let load_mtl = |name: &Path| {
        let full = base.join(name);
        let r = tobj::load_mtl(&full);
        if let Err(e) = &r {
            let why: Box<dyn std::error::Error + Send + Sync> = match std::fs::metadata(&full) {
                Err(io) => Box::new(io),
                Ok(_) => Box::new(*e),
            };
            failed_mtl.borrow_mut().get_or_insert((full, why));
        }
        r
    };
    // One index per corner: a vertex is split where its faces give it another normal (vn).
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let (models, materials) = tobj::load_obj_buf(obj, &opts, load_mtl).map_err(describe)?;
    if let Some((mtl, why)) = failed_mtl.into_inner() {
        return Err(ParseError::caused(format!("material library {}", mtl.display()), why));
    }
    let materials = materials.map_err(|e| ParseError::caused("material library", e))?;

    // Each material's diffuse texture, stored, or why it cannot be read.
    let mut textures = Textures::default();
    let mut files = std::collections::HashMap::new();
    let diffuse: Vec<Option<Result<u32, String>>> = materials
        .iter()
        .map(|m| {
            let file = m.diffuse_texture.as_ref()?;
            let image = match files.get(file) {
                Some(&k) => Ok(k),
                None => super::images::of_file(&base.join(file)).map(|image| {
                    textures.images.push(image);
                    files.insert(file.clone(), textures.images.len() as u32 - 1);
                    textures.images.len() as u32 - 1
                }),
            };
            let cutoff = (m.dissolve_texture.as_ref() == Some(file)).then_some(0.5);
            Some(image.map(|image| textures.add(Texture { image, sampler: Sampler::default(), cutoff })))
        })
        .collect();
    let points = models.iter().flat_map(|m| m.mesh.positions.chunks_exact(3)).map(|p| DVec3::new(p[0], p[1], p[2]));
    let anchor = crate::place::anchor(points);
    let objects = models
        .into_iter()
        .enumerate()
        .map(|(i, m)| {
            let p: Vec<[f64; 3]> = m.mesh.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
            let mut mesh = Mesh { positions: crate::place::relative(&p, anchor), indices: m.mesh.indices, ..Mesh::default() };
            if m.mesh.normals.len() == p.len() * 3 {
                let given = m.mesh.normals.chunks_exact(3).map(|n| DVec3::new(n[0], n[1], n[2]).as_vec3());
                mesh.normals = given.map(crate::normal::given).collect();
            }
            // Kd, the diffuse colour, as display values (what OBJ viewers show): times its
            // texture where sampled, else times the texture's mean; d below 1 is translucent.
            let material = m.mesh.material_id.and_then(|id| materials.get(id));
            let texture = m.mesh.material_id.and_then(|id| diffuse.get(id)?.as_ref()?.as_ref().ok().copied());
            if let Some(texture) = texture
                && m.mesh.texcoords.len() == p.len() * 2
            {
                let uv = m.mesh.texcoords.chunks_exact(2).map(|t| [t[0] as f32, (1.0 - t[1]) as f32]);
                mesh.texcoords = uv.map(|uv| Texcoord { uv, texture }).collect();
            }
            let mean = texture.filter(|_| mesh.texcoords.is_empty()).map(|t| {
                let m = crate::texture::mean(&textures.images[textures.textures[t as usize].image as usize]);
                [0, 1, 2].map(|k| crate::texture::linear_to_srgb(m[k]))
            });
            // A cut-out without Kd takes MTL's default, 0.8: its alpha must be stored.
            let cut_out = material.is_some_and(|mat| mat.dissolve_texture.is_some());
            let default = (cut_out || texture.is_some()).then_some([0.8; 3]);
            if let Some(kd) = material.and_then(|mat| mat.diffuse.or(default)) {
                let texel = |k: usize| mean.map_or(1.0, |m| m[k]);
                let c = |k: usize| ((kd[k] as f32 * texel(k)).clamp(0.0, 1.0) * 255.0).round() as u8;
                let d = material.and_then(|mat| mat.dissolve).unwrap_or(1.0);
                let a = match crate::mesh::alpha(d as f32) {
                    255 if cut_out => crate::mesh::CUT_OUT,
                    a => a,
                };
                mesh.paint([c(0), c(1), c(2), a]);
            }
            let name = if m.name.is_empty() { format!("object {i}") } else { m.name };
            Object::placed(name, mesh, anchor, DAffine3::IDENTITY)
        })
        .collect();
    Ok(Imported { objects, left_out: texture_notes(&materials, &diffuse), textures, ..Imported::default() })
}

/// What the build leaves out of the materials' textures: diffuse ones (map_Kd) it cannot read,
/// drawn in their Kd, and alpha ones (map_d) other than the diffuse texture itself, whose
/// surfaces are cut-outs drawn whole, each note naming its first few.
fn texture_notes(materials: &[tobj::Material], diffuse: &[Option<Result<u32, String>>]) -> Vec<String> {
    let sorted = |mut v: Vec<String>| {
        v.sort();
        v.dedup();
        v
    };
    let alpha = sorted(
        materials
            .iter()
            .filter_map(|m| m.dissolve_texture.as_ref().filter(|&d| m.diffuse_texture.as_ref() != Some(d)).map(|t| format!("'{t}'")))
            .collect(),
    );
    let unread = sorted(
        materials
            .iter()
            .zip(diffuse)
            .filter_map(|(m, d)| Some(format!("'{}' ({})", m.diffuse_texture.as_ref()?, d.as_ref()?.as_ref().err()?)))
            .collect(),
    );
    let alpha = (!alpha.is_empty()).then(|| {
        format!(
            "{} alpha textures (map_d) apart from their diffuse texture (their surfaces are cut-outs, drawn whole, occluding nothing): {}",
            alpha.len(),
            first_few(&alpha)
        )
    });
    let unread = (!unread.is_empty())
        .then(|| format!("{} diffuse textures that cannot be read (drawn in their Kd): {}", unread.len(), first_few(&unread)));
    alpha.into_iter().chain(unread).collect()
}

fn describe(e: tobj::LoadError) -> ParseError {
    match e {
        tobj::LoadError::FaceVertexOutOfBounds => ParseError::new("a face names a vertex the file does not have (index out of range)"),
        e => ParseError::caused("not a valid OBJ file", e),
    }
}
