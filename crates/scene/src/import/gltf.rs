//! glTF 2.0 reader (.gltf with external or embedded buffers, .glb): the default scene's whole
//! node hierarchy with transforms; every triangle primitive (indexed or not) becomes one object
//! per mesh instance. Other primitive modes are skipped with a warning. Images are never
//! decoded. Every accessor is checked against its buffer before it is read.

use super::{ImportError, Imported};
use crate::mesh::{Mesh, Object};
use glam::{Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use std::path::Path;

/// Reads the glTF or GLB file at `path`, loading its buffers (files beside it or data URIs).
pub fn read(path: &Path) -> Result<Imported, ImportError> {
    let bad = |what: String| ImportError::Malformed { path: path.to_owned(), what };
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io { path: path.to_owned(), source })?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| bad(format!("not valid glTF: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers =
        gltf::import_buffers(&gltf.document, Some(base), gltf.blob.clone()).map_err(|e| bad(format!("cannot load a buffer: {e}")))?;
    let buffers: Vec<&[u8]> = buffers.iter().map(|b| b.0.as_slice()).collect();
    let doc = &gltf.document;
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => doc.nodes().filter(|n| !doc.nodes().any(|p| p.children().any(|c| c.index() == n.index()))).collect(),
    };
    let mut out = Imported::default();
    let mut stack: Vec<(gltf::Node, Mat4, usize)> = roots.into_iter().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 256 {
            return Err(bad("node hierarchy deeper than 256 (a cycle?)".into()));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if !world.is_finite() {
            return Err(bad(format!("node {} has a non-finite transform", node.index())));
        }
        if let Some(mesh) = node.mesh() {
            let mut m = Mesh::default();
            for prim in mesh.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    out.skipped.push(format!(
                        "mesh {} primitive {}: mode {:?} is not a triangle list",
                        mesh.index(),
                        prim.index(),
                        prim.mode()
                    ));
                    continue;
                }
                let part = primitive(&prim, &buffers).map_err(|e| bad(format!("mesh {} primitive {}: {e}", mesh.index(), prim.index())))?;
                m.append(&part);
            }
            for p in &mut m.positions {
                *p = world.transform_point3(Vec3::from_array(*p)).to_array();
            }
            let name = node.name().or(mesh.name()).map(str::to_owned).unwrap_or_else(|| format!("node {}", node.index()));
            out.objects.push(Object { name, mesh: m });
        }
        stack.extend(node.children().map(|c| (c, world, depth + 1)));
    }
    Ok(out)
}

fn primitive(prim: &gltf::Primitive, buffers: &[&[u8]]) -> Result<Mesh, String> {
    let pos = prim.get(&gltf::Semantic::Positions).ok_or("no POSITION attribute")?;
    if pos.data_type() != DataType::F32 || pos.dimensions() != Dimensions::Vec3 {
        return Err(format!("POSITION is {:?} {:?}, expected float VEC3", pos.data_type(), pos.dimensions()));
    }
    check(&pos, buffers)?;
    if let Some(idx) = prim.indices() {
        check(&idx, buffers)?;
    }
    let reader = prim.reader(|b| buffers.get(b.index()).copied());
    let positions: Vec<[f32; 3]> = reader.read_positions().ok_or("POSITION data missing")?.collect();
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..positions.len() as u32).collect(),
    };
    Ok(Mesh { positions, indices })
}

/// Checks that `acc` lies inside its buffer view and the view inside its buffer, so that
/// reading it cannot go out of bounds.
fn check(acc: &gltf::Accessor, buffers: &[&[u8]]) -> Result<(), String> {
    if acc.sparse().is_some() {
        return Err(format!("accessor {} is sparse (not supported)", acc.index()));
    }
    let view = acc.view().ok_or(format!("accessor {} has no buffer view", acc.index()))?;
    let len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
    let elem = acc.size();
    let stride = view.stride().unwrap_or(elem).max(elem);
    let view_end = view.offset().checked_add(view.length());
    let need = match acc.count() {
        0 => 0,
        n => acc.offset() + (n - 1) * stride + elem,
    };
    if view_end.is_none_or(|e| e > len) || need > view.length() {
        return Err(format!(
            "accessor {} reaches past the end of its buffer (buffer {} has {len} bytes)",
            acc.index(),
            view.buffer().index()
        ));
    }
    Ok(())
}
