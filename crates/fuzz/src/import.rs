//! The model readers: glTF and GLB (with KHR_mesh_quantization, EXT_meshopt_compression's
//! decoders and EXT_mesh_gpu_instancing), OBJ and PLY. Whatever a reader accepts must be safe
//! to build from: placement around one origin and the clean-up run on it without a panic,
//! and a mesh the clean-up keeps has every index in range and every position finite.

use osw_scene::import::{Imported, gltf, obj, ply};
use std::path::Path;

/// External files are looked up here: nowhere.
const NO_DIR: &str = "/nonexistent/osw-fuzz";

fn check(imported: Imported) {
    let (objects, origin) = osw_scene::place::place(imported.objects);
    assert!(origin.is_finite(), "origin {origin}");
    for o in objects {
        if let Ok((mesh, _)) = o.mesh.clean() {
            assert!(mesh.indices.iter().all(|&i| (i as usize) < mesh.positions.len()), "index out of range after clean-up");
            assert!(mesh.positions.iter().flatten().all(|c| c.is_finite()), "non-finite position after clean-up");
        }
    }
}

pub fn run_gltf(data: &[u8]) {
    if let Ok(imported) = gltf::parse(data, Path::new(NO_DIR)) {
        check(imported);
    }
}

pub fn run_obj(data: &[u8]) {
    if let Ok(imported) = obj::parse(&mut std::io::Cursor::new(data), Path::new(NO_DIR)) {
        check(imported);
    }
}

pub fn run_ply(data: &[u8]) {
    if let Ok(o) = ply::parse(data) {
        check(Imported { objects: vec![o], ..Imported::default() });
    }
}
