//! What the caller chooses of a build.

/// Settings of a build.
#[derive(Clone, Debug)]
pub struct BuildOptions {
    /// Largest chunk, triangles (>= 1).
    pub chunk_triangles: u32,
    /// Split chunks whose halves' boxes have less than this fraction of their box's surface
    /// area (0: never; see [`crate::limits::LOOSE_SPLIT`]).
    pub loose_split: f32,
    /// Keep the model's colours (false: every object in its hashed colour).
    pub model_colors: bool,
    /// Normals stored for shading: the model's and computed ones, or none.
    pub normals: crate::smooth::Normals,
    /// Keep the model's single-sided surfaces (false: every surface double-sided, for a model
    /// whose winding is not to be trusted).
    pub model_sides: bool,
    /// Most input triangles built in memory at once (see [`crate::limits::BUCKET_TRIANGLES`]).
    pub bucket_triangles: u64,
    /// Static LOD chains per chunk, or a cluster hierarchy per object.
    pub lod: Lod,
    /// A mesh that the input uses several times: stored once, or a copy per use.
    pub instances: Instances,
    /// Look for objects whose mesh repeats an earlier one's up to a translation where the
    /// input does not say so ([`crate::repeat`]): on for files, off for the generators, whose
    /// scenes stay as every earlier figure measured them (the plain plant repeats its
    /// walkways and railings bay to bay: 13,351 objects of the 20M plant would be found).
    pub find_repeats: bool,
}

/// What the build does with a mesh the input uses several times (a glTF mesh of several nodes,
/// EXT_mesh_gpu_instancing). Both clean and cut it in its own frame and build its LOD chains
/// once; `Expand` then writes each use's copy, placed, where `Keep` writes the use's transform.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Instances {
    #[default]
    Keep,
    Expand,
}

impl std::str::FromStr for Instances {
    type Err = String;

    fn from_str(s: &str) -> Result<Instances, String> {
        match s {
            "keep" => Ok(Instances::Keep),
            "expand" => Ok(Instances::Expand),
            _ => Err(format!("{s:?}: expected keep or expand")),
        }
    }
}

/// How a scene's detail is reduced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lod {
    /// A chain of levels per chunk, borders locked, chosen whole (occlusion switch sec. 4.1).
    #[default]
    Chains,
    /// A cluster hierarchy per object whose detail varies across a surface ([`crate::clod`]).
    Clusters,
}

impl std::str::FromStr for Lod {
    type Err = String;

    fn from_str(s: &str) -> Result<Lod, String> {
        match s {
            "chains" => Ok(Lod::Chains),
            "clusters" => Ok(Lod::Clusters),
            _ => Err(format!("{s:?}: expected chains or clusters")),
        }
    }
}

impl std::fmt::Display for Lod {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(if *self == Lod::Chains { "chains" } else { "clusters" })
    }
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            chunk_triangles: crate::limits::CHUNK_TRIANGLES,
            loose_split: crate::limits::LOOSE_SPLIT,
            model_colors: true,
            normals: crate::smooth::Normals::default(),
            model_sides: true,
            bucket_triangles: crate::limits::BUCKET_TRIANGLES,
            lod: Lod::Chains,
            instances: Instances::Keep,
            find_repeats: false,
        }
    }
}
