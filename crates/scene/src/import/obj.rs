//! Wavefront OBJ reader (through `tobj`, positions in f64): every object (`o`) and group (`g`)
//! becomes an object, polygons are fanned into triangles, negative (relative) indices are
//! resolved; points and lines are skipped. The material libraries it names (`mtllib`, beside
//! the file) must be readable; an object's material gives its colour (Kd) and, with d below 1,
//! its translucency; one with an alpha texture (map_d) is a cut-out ([`crate::mesh::CUT_OUT`]).
//! Textures are not sampled: a diffuse texture (map_Kd) multiplies Kd by its mean colour, and
//! `left_out` names them. All objects of a file share one f32 anchor
//! (see [`crate::place`]).

use super::{ImportError, Imported, ParseError, first_few};
use crate::mesh::{Mesh, Object};
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

    // Each diffuse texture's mean colour, as displayed, or why it cannot be read.
    let means: Vec<Option<Result<[f32; 3], String>>> = materials
        .iter()
        .map(|m| {
            let mean = |t: &String| {
                super::texture_mean::of_file(&base.join(t)).map(|c| [0, 1, 2].map(|k| super::texture_mean::linear_to_srgb(c[k])))
            };
            m.diffuse_texture.as_ref().map(mean)
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
            // Kd, the diffuse colour, as display values (what OBJ viewers show), times its
            // texture's mean where it has one; d below 1 is translucent.
            let material = m.mesh.material_id.and_then(|id| materials.get(id));
            let mean = m.mesh.material_id.and_then(|id| means.get(id)?.as_ref()?.as_ref().ok());
            // A cut-out without Kd takes MTL's default, 0.8: its alpha must be stored.
            let cut_out = material.is_some_and(|mat| mat.dissolve_texture.is_some());
            let default = (cut_out || mean.is_some()).then_some([0.8; 3]);
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
    Ok(Imported { objects, left_out: texture_notes(&materials, &means), ..Imported::default() })
}

/// One of a material's texture maps.
type Map = fn(&tobj::Material) -> Option<&String>;

/// The textures of `materials`, which the build does not sample: the diffuse ones (map_Kd),
/// drawn as their mean colour where `means` could read them, and the alpha ones (map_d) of
/// cut-outs, each note naming its first few.
fn texture_notes(materials: &[tobj::Material], means: &[Option<Result<[f32; 3], String>>]) -> Vec<String> {
    let named = |texture: Map| {
        let mut names: Vec<String> = materials.iter().filter_map(texture).map(|t| format!("'{t}'")).collect();
        names.sort();
        names.dedup();
        (materials.iter().filter(|m| texture(m).is_some()).count(), names)
    };
    let kinds: [(Map, &str, &str); 2] = [
        (
            |m| m.diffuse_texture.as_ref(),
            "diffuse textures (map_Kd)",
            "textures are not sampled: those surfaces are drawn in their Kd times the texture's mean colour",
        ),
        (|m| m.dissolve_texture.as_ref(), "alpha textures (map_d)", "their surfaces are cut-outs, drawn whole, occluding nothing"),
    ];
    let notes = kinds.into_iter().map(|(texture, what, why)| {
        let (uses, names) = named(texture);
        (uses > 0).then(|| format!("{} {what} of {uses} materials ({why}): {}", names.len(), first_few(&names)))
    });
    let mut unread: Vec<String> = materials
        .iter()
        .zip(means)
        .filter_map(|(m, mean)| Some(format!("'{}' ({})", m.diffuse_texture.as_ref()?, mean.as_ref()?.as_ref().err()?)))
        .collect();
    unread.sort();
    unread.dedup();
    let unread = (!unread.is_empty())
        .then(|| format!("{} diffuse textures that cannot be read (drawn in their Kd): {}", unread.len(), first_few(&unread)));
    notes.flatten().chain(unread).collect()
}

fn describe(e: tobj::LoadError) -> ParseError {
    match e {
        tobj::LoadError::FaceVertexOutOfBounds => ParseError::new("a face names a vertex the file does not have (index out of range)"),
        e => ParseError::caused("not a valid OBJ file", e),
    }
}
