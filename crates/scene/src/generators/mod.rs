//! Procedural scenes, deterministic for a seed, sized by a triangle budget: the CHC city and
//! teapot scenes (CHC sec. 6.1), the power plant of the occlusion switch, CHC and Yoon 2003, the forest of
//! Bartz 1999 and Yoon 2003's isosurface.
//!
//! Units are metres; the ground is at y = 0. Each generator first measures the average cost of
//! its repeating unit (a building, a teapot, a plant bay) on a sample, then lays out as many
//! units as the budget pays for, so the result is within a few percent of the budget.

pub mod city;
pub mod forest;
pub mod isosurface;
pub mod plant;
pub mod shapes;
pub mod teapots;

use crate::mesh::Object;

/// Which generator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GenKind {
    City,
    Teapots,
    Plant,
    Forest,
    Isosurface,
}

impl std::str::FromStr for GenKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "city" => Ok(GenKind::City),
            "teapots" => Ok(GenKind::Teapots),
            "plant" => Ok(GenKind::Plant),
            "forest" => Ok(GenKind::Forest),
            "isosurface" => Ok(GenKind::Isosurface),
            _ => Err(format!("unknown generator {s:?}: expected city, teapots, plant, forest or isosurface")),
        }
    }
}

/// What a generator made, and anything a user should know about how.
pub struct Generated {
    pub objects: Vec<Object>,
    pub notes: Vec<String>,
}

/// Generator `kind`'s scene (as [`generate`]) built with the default options into `path` and
/// opened: what the tests and benches that draw start from.
pub fn build_generated(kind: GenKind, triangles: u64, seed: u64, path: &std::path::Path) -> Result<crate::SceneFile, GeneratedError> {
    let g = generate(kind, triangles, seed);
    crate::build_scene(g.objects, &format!("{kind:?}"), g.notes, &Default::default(), path, std::time::Instant::now(), &())?;
    Ok(crate::SceneFile::open(path)?)
}

/// Why [`build_generated`] gave no scene: the build failed, or what it wrote does not open.
#[derive(Debug, thiserror::Error)]
pub enum GeneratedError {
    #[error(transparent)]
    Build(#[from] crate::build::BuildError),
    #[error(transparent)]
    Open(#[from] crate::SceneError),
}

/// Runs generator `kind` for about `triangles` triangles (at least 1,000) with `seed`.
pub fn generate(kind: GenKind, triangles: u64, seed: u64) -> Generated {
    let triangles = triangles.max(1_000);
    match kind {
        GenKind::City => Generated { objects: city::generate(triangles, seed), notes: Vec::new() },
        GenKind::Plant => Generated { objects: plant::generate(triangles, seed), notes: Vec::new() },
        GenKind::Teapots => teapots::generate(triangles, seed),
        GenKind::Forest => Generated { objects: forest::generate(triangles, seed), notes: Vec::new() },
        GenKind::Isosurface => Generated { objects: isosurface::generate(triangles, seed), notes: Vec::new() },
    }
}

/// The seeded generator every generator uses.
pub(crate) fn rng(seed: u64, stream: u64) -> rand_pcg::Pcg64Mcg {
    use rand::SeedableRng;
    rand_pcg::Pcg64Mcg::seed_from_u64(seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// Triangles of a list of objects.
pub(crate) fn triangles_of(objects: &[Object]) -> u64 {
    objects.iter().map(|o| o.mesh.triangle_count() as u64).sum()
}
