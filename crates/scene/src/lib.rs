//! osw scene: everything the three processes of the cluster share (occlusion switch, sec. 3.5 and 4.1).
//!
//! Layout of this crate, in the order a scene is made:
//! - [`mesh`]: indexed triangle meshes and the clean-up every input goes through.
//! - [`import`]: glTF 2.0 (.gltf/.glb) and PLY readers; [`generators`]: the city, teapots and plant
//!   generators.
//! - [`normal`] and [`smooth`]: normals stored in 4 bytes, and computed where a model gives none.
//! - [`place`]: one scene origin for the objects' f64 world coordinates, scene-local f32.
//! - [`instance`]: a mesh used several times stored once, and how one use places its blocks.
//! - [`chunk`]: splits large objects into chunks of bounded triangle count, and halves chunks
//!   whose box is loose.
//! - [`bvh`]: the SAH bounding volume hierarchy over chunks.
//! - [`lod`] and [`hlod`]: static LOD chains per leaf, HLODs per interior node; or [`clod`]: a
//!   cluster hierarchy per object, its simplified groups owned by BVH nodes; [`deviation`]:
//!   how far a simplified mesh lies from its input, measured.
//! - [`build`]: the pipeline above, out of core ([`source`] streams the input, the build's
//!   stages chunk it into the [`spill`] file and build the hierarchy's geometry a subtree at a
//!   time), its options, its report of what it left out, and its errors; [`progress`] for long
//!   work.
//! - [`format`], [`block`], [`writer`] and [`file`]: the versioned, hashed, memory-mapped scene
//!   file, its geometry blocks encoded and decoded in one place.
//! - [`error_metric`]: object-space error projected to pixels (tau); [`error_check`]: the
//!   stored errors measured against the full detail they stand for.
//! - [`camera`] and [`path`]: cameras, the path CSV, and walk/orbit/flyover paths.

pub mod aabb;
mod append;
pub mod block;
pub mod build;
pub mod bvh;
pub mod camera;
pub mod chunk;
pub mod clod;
pub mod cluster;
pub mod deviation;
pub mod error_check;
pub mod error_metric;
pub mod file;
pub mod fins;
pub mod format;
pub mod generators;
pub mod hlod;
pub mod import;
pub mod instance;
pub mod limits;
pub mod lod;
pub mod mesh;
pub mod mip;
pub mod nav;
pub mod normal;
pub mod path;
pub mod path_gen;
pub mod place;
pub mod progress;
pub mod repeat;
pub mod smooth;
pub mod source;
pub mod spill;
pub mod texture;
pub mod writer;

pub use aabb::Aabb;
pub use build::{BuildOptions, BuildReport, build, build_scene};
pub use camera::Camera;
pub use file::{SceneError, SceneFile};
pub use format::{NodeId, NodeKind, NodeRecord};
pub use mesh::Mesh;
