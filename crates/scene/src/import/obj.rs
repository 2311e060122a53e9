//! Wavefront OBJ reader (through `tobj`, positions in f64): every object (`o`) and group (`g`)
//! becomes an object, polygons are fanned into triangles, negative (relative) indices are
//! resolved; points and lines are skipped. The material libraries it names (`mtllib`, beside
//! the file) must be readable. All objects of a file share one f32 anchor (see
//! [`crate::place`]).

use super::{ImportError, Imported};
use crate::mesh::{Mesh, Object};
use glam::{DAffine3, DVec3};
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// Reads the OBJ file at `path` and the material libraries it names.
pub fn read(path: &Path) -> Result<Imported, ImportError> {
    let bad = |what: String| ImportError::Malformed { path: path.to_owned(), what };
    let file = std::fs::File::open(path).map_err(|error| ImportError::Io { path: path.to_owned(), error })?;
    let base = path.parent().unwrap_or(Path::new(".")).to_owned();
    let failed_mtl: RefCell<Option<(PathBuf, String)>> = RefCell::new(None);
    let load_mtl = |name: &Path| {
        let full = base.join(name);
        let r = tobj::load_mtl(&full);
        if let Err(e) = &r {
            let why = match std::fs::metadata(&full) {
                Err(io) => io.to_string(),
                Ok(_) => e.to_string(),
            };
            failed_mtl.borrow_mut().get_or_insert((full, why));
        }
        r
    };
    let opts = tobj::LoadOptions { triangulate: true, ignore_points: true, ignore_lines: true, ..Default::default() };
    let (models, materials) = tobj::load_obj_buf(&mut std::io::BufReader::new(file), &opts, load_mtl).map_err(|e| bad(describe(e)))?;
    if let Some((mtl, why)) = failed_mtl.into_inner() {
        return Err(bad(format!("material library {}: {why}", mtl.display())));
    }
    materials.map_err(|e| bad(format!("material library: {e}")))?;

    let points = models.iter().flat_map(|m| m.mesh.positions.chunks_exact(3)).map(|p| DVec3::new(p[0], p[1], p[2]));
    let anchor = crate::place::anchor(points);
    let objects = models
        .into_iter()
        .enumerate()
        .map(|(i, m)| {
            let p: Vec<[f64; 3]> = m.mesh.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
            let mesh = Mesh { positions: crate::place::relative(&p, anchor), indices: m.mesh.indices };
            let name = if m.name.is_empty() { format!("object {i}") } else { m.name };
            Object { name, mesh, placement: DAffine3::from_translation(anchor) }
        })
        .collect();
    Ok(Imported { objects, skipped: Vec::new() })
}

fn describe(e: tobj::LoadError) -> String {
    match e {
        tobj::LoadError::FaceVertexOutOfBounds => "a face names a vertex the file does not have (index out of range)".into(),
        e => format!("not a valid OBJ file: {e}"),
    }
}
