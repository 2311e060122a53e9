//! What the `gltf` crate reads in f32 or not at all, read again from the document's JSON: node
//! transforms in f64 (georeferenced models put site coordinates, 1e6-1e9 units, in their root
//! node, where f32 is off by up to 32 units), and the extensions osw reads itself
//! (EXT_meshopt_compression, EXT_mesh_gpu_instancing) or refuses (KHR_draco_mesh_compression).

use super::ParseError;
use glam::{DMat4, DQuat, DVec3};
use serde::Deserialize;
use std::collections::BTreeMap;

/// The extensions a file may require: those osw reads, and those that change nothing osw reads
/// (materials and textures; osw does not decode images).
pub const READ: &[&str] = &["KHR_mesh_quantization", "EXT_meshopt_compression", "EXT_mesh_gpu_instancing"];
const IGNORABLE_PREFIXES: &[&str] = &["KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_punctual"];
pub const DRACO: &str = "KHR_draco_mesh_compression";

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Raw {
    pub nodes: Vec<Node>,
    pub buffers: Vec<Buffer>,
    pub buffer_views: Vec<View>,
    pub meshes: Vec<Mesh>,
    pub accessors: Vec<serde::de::IgnoredAny>,
    pub extensions_required: Vec<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct Node {
    pub matrix: Option<[f64; 16]>,
    pub translation: Option<[f64; 3]>,
    pub rotation: Option<[f64; 4]>,
    pub scale: Option<[f64; 3]>,
    pub extensions: NodeExtensions,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct NodeExtensions {
    #[serde(rename = "EXT_mesh_gpu_instancing")]
    pub instancing: Option<Instancing>,
}

/// EXT_mesh_gpu_instancing: accessors of per-instance TRANSLATION, ROTATION and SCALE.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct Instancing {
    pub attributes: BTreeMap<String, usize>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct Buffer {
    pub extensions: BufferExtensions,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct BufferExtensions {
    #[serde(rename = "EXT_meshopt_compression")]
    pub meshopt: Option<MeshoptBuffer>,
}

/// A buffer marked `fallback` holds no data (and has no URI): the compressed views decode into
/// it.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct MeshoptBuffer {
    pub fallback: bool,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct View {
    pub extensions: ViewExtensions,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct ViewExtensions {
    #[serde(rename = "EXT_meshopt_compression")]
    pub meshopt: Option<MeshoptView>,
}

/// EXT_meshopt_compression on a buffer view: where its compressed bytes are and how to decode
/// them into the view.
#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct MeshoptView {
    pub buffer: usize,
    pub byte_offset: usize,
    pub byte_length: usize,
    pub byte_stride: usize,
    pub count: usize,
    pub mode: String,
    pub filter: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct Mesh {
    pub primitives: Vec<Primitive>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct Primitive {
    pub attributes: BTreeMap<String, serde_json::Value>,
    pub extensions: BTreeMap<String, serde::de::IgnoredAny>,
}

impl Raw {
    /// Refuses a file that requires an extension osw cannot honour, naming it; Draco with how
    /// to re-export.
    pub fn check_extensions(&self) -> Result<(), ParseError> {
        let draco = self.meshes.iter().flat_map(|m| &m.primitives).any(|p| p.extensions.contains_key(DRACO));
        if draco || self.extensions_required.iter().any(|e| e == DRACO) {
            return Err(ParseError::new(format!(
                "{DRACO}: Draco-compressed meshes are not read (no well-kept pure-Rust decoder); re-export without Draco, \
                 e.g. `gltfpack -i in.glb -o out.glb` (quantized, or -cc for EXT_meshopt_compression) or \
                 `gltf-transform meshopt in.glb out.glb`"
            )));
        }
        match self.extensions_required.iter().find(|e| !READ.contains(&e.as_str()) && !IGNORABLE_PREFIXES.iter().any(|p| e.starts_with(p)))
        {
            Some(e) => Err(ParseError::new(format!("requires extension {e}, which osw does not read (it reads {})", READ.join(", ")))),
            None => Ok(()),
        }
    }
}

impl Raw {
    /// Checks what the `gltf` crate's validation reads unchecked (gltf-json 1.4.1 indexes the
    /// accessor of a primitive's POSITION before checking that it exists, and panics).
    pub fn check_attributes(&self) -> Result<(), ParseError> {
        for (m, mesh) in self.meshes.iter().enumerate() {
            for (p, prim) in mesh.primitives.iter().enumerate() {
                for (name, index) in &prim.attributes {
                    if index.as_u64().is_none_or(|i| i >= self.accessors.len() as u64) {
                        return Err(ParseError::new(format!(
                            "meshes[{m}].primitives[{p}].attributes.{name}: accessor {index} does not exist"
                        )));
                    }
                }
            }
        }
        Ok(())
    }
}

impl Node {
    /// The node's transform relative to its parent, in f64 (glTF 2.0 sec. 3.5.3: a matrix, or
    /// T · R · S).
    pub fn local(&self) -> DMat4 {
        if let Some(m) = self.matrix {
            return DMat4::from_cols_array(&m);
        }
        let t = self.translation.map_or(DVec3::ZERO, DVec3::from_array);
        let r = self.rotation.map_or(DQuat::IDENTITY, |q| DQuat::from_array(q).normalize());
        let s = self.scale.map_or(DVec3::ONE, DVec3::from_array);
        DMat4::from_scale_rotation_translation(s, r, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transforms_keep_f64_precision() {
        let raw: Raw = serde_json::from_str(
            r#"{"nodes":[{"translation":[4512345.678,12.5,-1000000000.25]},{"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,1e7,2,3,1]}]}"#,
        )
        .unwrap();
        assert_eq!(raw.nodes[0].local().w_axis.truncate(), DVec3::new(4_512_345.678, 12.5, -1_000_000_000.25));
        assert_eq!(raw.nodes[1].local().w_axis.truncate(), DVec3::new(1e7, 2.0, 3.0));
    }

    #[test]
    fn draco_and_unknown_required_extensions_are_refused_by_name() {
        let raw: Raw = serde_json::from_str(r#"{"meshes":[{"primitives":[{"extensions":{"KHR_draco_mesh_compression":{}}}]}]}"#).unwrap();
        let e = raw.check_extensions().unwrap_err().to_string();
        assert!(e.contains("KHR_draco_mesh_compression") && e.contains("gltfpack"), "{e}");
        let raw: Raw = serde_json::from_str(r#"{"extensionsRequired":["KHR_mesh_quantization","EXT_weird"]}"#).unwrap();
        assert!(raw.check_extensions().unwrap_err().to_string().contains("EXT_weird"));
        let raw: Raw = serde_json::from_str(r#"{"extensionsRequired":["KHR_mesh_quantization","KHR_texture_basisu"]}"#).unwrap();
        assert!(raw.check_extensions().is_ok());
    }

    #[test]
    fn attributes_naming_missing_accessors_are_refused() {
        let raw: Raw = serde_json::from_str(r#"{"accessors":[{}],"meshes":[{"primitives":[{"attributes":{"POSITION":1}}]}]}"#).unwrap();
        assert!(raw.check_attributes().unwrap_err().to_string().contains("POSITION: accessor 1 does not exist"));
        let raw: Raw = serde_json::from_str(r#"{"accessors":[{}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#).unwrap();
        assert!(raw.check_attributes().is_ok());
    }
}
