//! Static LOD chains for leaves (occlusion switch sec. 4.1), made with meshoptimizer's
//! edge-collapse simplifier. Chunk borders are locked so that neighbouring chunks of one
//! object at different levels still meet without cracks. A textured chunk is simplified with
//! its texture coordinates as attributes (meshoptimizer's attribute-aware quadrics): a collapse
//! that slides the texture across the surface costs as a geometric one does, so a flat but
//! textured surface keeps the vertices its mapping needs, and its level's error includes that
//! slide. UV seams and a cut-out's border are vertices split by their attributes: kept.
//!
//! Errors: meshoptimizer reports each step's error relative to the mesh's extent, as quadric
//! errors (distances to the input's planes); each step's error is that or the distance measured
//! from its input to its result ([`crate::deviation`]), whichever is larger, and the object
//! error of level k is the sum of the steps', an upper bound on the distance to the original by
//! the triangle inequality. Levels are simplified one from the next (cost
//! 1 + 1/4 + 1/16 ... of the chunk instead of one pass per level).

use crate::limits::{LOD_MAX_LEVELS, LOD_MIN_REDUCTION, LOD_MIN_TRIANGLES, LOD_TARGET_RATIO};
use crate::mesh::Mesh;

/// Weight of a texture coordinate's change against a position's (meshoptimizer scales
/// positions to the mesh's extent): sliding the texture by its whole width costs as much as
/// moving the surface by the chunk's size.
const UV_WEIGHT: f32 = 1.0;

/// One level of a chain: geometry and its object-space error (world units).
#[derive(Clone, Debug)]
pub struct Level {
    pub mesh: Mesh,
    pub error: f32,
}

/// Why a chain stopped: the build report counts these.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LodStats {
    /// Chunks too small to simplify at all (at most LOD_MIN_TRIANGLES triangles).
    pub too_small: u64,
    /// Levels simplified and dropped because they did not cut enough triangles.
    pub not_paying: u64,
    /// Chains that reached LOD_MAX_LEVELS.
    pub max_levels: u64,
}

impl LodStats {
    pub fn add(&mut self, o: LodStats) {
        self.too_small += o.too_small;
        self.not_paying += o.not_paying;
        self.max_levels += o.max_levels;
    }
}

/// The chain for `mesh`: level 0 is `mesh` itself with error 0, then coarser levels with
/// increasing error, each at most LOD_MIN_REDUCTION of the previous one's triangles.
/// `min_error` (> 0) is the smallest error a simplified level may report.
pub fn chain(mesh: Mesh, min_error: f32) -> (Vec<Level>, LodStats) {
    let mut stats = LodStats::default();
    if mesh.triangle_count() <= LOD_MIN_TRIANGLES as usize {
        stats.too_small += 1;
        return (vec![Level { mesh, error: 0.0 }], stats);
    }
    let scale = meshopt::simplify_scale_decoder(&mesh.positions);
    let mut levels = vec![Level { mesh, error: 0.0 }];
    loop {
        let prev = levels.last().expect("level 0");
        let target = ((prev.mesh.indices.len() as f32 * LOD_TARGET_RATIO) as usize / 3 * 3).max(3);
        let pays = |indices: &[u32]| !indices.is_empty() && indices.len() as f32 <= prev.mesh.indices.len() as f32 * LOD_MIN_REDUCTION;
        let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&prev.mesh.positions), 12, 0).expect("12-byte vertices");
        let uv: Vec<f32> = prev.mesh.texcoords.iter().flat_map(|t| t.uv).collect();
        let unlocked = vec![false; if uv.is_empty() { 0 } else { prev.mesh.positions.len() }];
        // Pruning removes whole disconnected parts (bolts, grating) at an error of their
        // radius; collapsing alone keeps them but may flatten a thin part to nothing. Both are
        // tried where pruning reaches the step, and the one that buys its triangles cheaper is
        // kept (the smaller product of error and triangles: on a curved surface the triangles a
        // level needs grow about as 1/error), each at its measured error (crate::deviation).
        // Where pruning cannot reach the step the chain ends: collapsing alone then gains
        // little with the borders locked, and a stored-once part's stand-ins go on
        // (crate::hlod::stand_ins).
        // Error limit 1.0 (relative): no limit, the level's error is measured, not bounded.
        let simplify = |opts| {
            let mut rel = 0.0f32;
            let indices = if uv.is_empty() {
                meshopt::simplify(&prev.mesh.indices, &adapter, target, 1.0, opts, Some(&mut rel))
            } else {
                let (i, a) = (&prev.mesh.indices, &adapter);
                meshopt::simplify_with_attributes_and_locks(i, a, &uv, &[UV_WEIGHT; 2], 8, &unlocked, target, 1.0, opts, Some(&mut rel))
            };
            (indices, rel)
        };
        let (mut indices, mut rel) = simplify(meshopt::SimplifyOptions::LockBorder | meshopt::SimplifyOptions::Prune);
        if !pays(&indices) {
            stats.not_paying += 1;
            break;
        }
        let (collapsed, collapsed_rel) = simplify(meshopt::SimplifyOptions::LockBorder);
        if pays(&collapsed) && collapsed_rel * (collapsed.len() as f32) < rel * indices.len() as f32 {
            (indices, rel) = (collapsed, collapsed_rel);
        }
        let mesh = prev.mesh.sub_mesh(&indices);
        // Quadric errors are distances to the input's planes; the distance itself is measured.
        let step = crate::deviation::one_sided(&prev.mesh, &mesh, rel * scale, 1);
        let error = prev.error + step.max(min_error);
        let small = mesh.triangle_count() <= LOD_MIN_TRIANGLES as usize;
        levels.push(Level { mesh, error });
        if levels.len() == LOD_MAX_LEVELS {
            stats.max_levels += 1;
            break;
        }
        if small {
            break;
        }
    }
    (levels, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;
    use glam::Vec3;

    #[test]
    fn a_fine_sphere_gets_a_chain_of_coarser_levels_with_growing_error() {
        let mut m = Mesh::default();
        shapes::lathe(&mut m, Vec3::ZERO, &shapes::sphere_profile(1.0, 32), 64); // ~4000 triangles
        let (levels, _) = chain(m, 1e-6);
        assert!(levels.len() >= 3, "{} levels", levels.len());
        for w in levels.windows(2) {
            assert!(w[1].mesh.triangle_count() as f32 <= w[0].mesh.triangle_count() as f32 * LOD_MIN_REDUCTION);
            assert!(w[1].error > w[0].error);
        }
        // The coarse level of a unit sphere deviates by less than its radius.
        assert!(levels.last().unwrap().error < 1.0);
    }

    #[test]
    fn a_floor_of_thin_columns_reports_what_its_levels_drop() {
        // The plant's floor structure: slabs and I-beam columns 6 m tall, 0.3 m across. Edge
        // collapse flattens a column onto its axis at a quadric error of its width, but a
        // flattened column has no area left: it is gone, as far as 6 m from what remains.
        let objects = crate::generators::plant::generate(2_000_000, 1);
        let floor = objects.iter().find(|o| o.name.starts_with("structure floor 1")).expect("a floor");
        let chunks = crate::chunk::split(&floor.mesh, crate::chunk::SplitOptions { max_triangles: 4096, loose: 0.0 });
        let chunk = chunks.meshes.into_iter().max_by_key(|m| m.triangle_count()).unwrap();
        let (levels, _) = chain(chunk, 1e-6);
        assert!(levels.len() >= 2, "{} levels", levels.len());
        assert!(levels[1].mesh.triangle_count() * 2 < levels[0].mesh.triangle_count());
        for (k, l) in levels.iter().enumerate().skip(1) {
            let far = crate::deviation::one_sided(&levels[0].mesh, &l.mesh, 0.0, 1);
            assert!(l.error >= far * 0.99, "level {k}: error {} m, but the chunk lies up to {far} m from it", l.error);
        }
        assert!(levels[1].error > 1.0, "level 1 at {} m: no column dropped, the test tests nothing", levels[1].error);
    }

    /// A flat grid whose texture is mapped unevenly (u grows as x squared): without its
    /// coordinates a flat surface collapses to its border at no error and the texture slides
    /// across it; with them, level 1 keeps the mapping's shape.
    #[test]
    fn a_flat_textured_surface_keeps_the_vertices_its_mapping_needs() {
        let n = 32;
        let mut m = Mesh::default();
        for y in 0..=n {
            for x in 0..=n {
                let (fx, fy) = (x as f32 / n as f32, y as f32 / n as f32);
                m.positions.push([fx, fy, 0.0]);
                m.texcoords.push(crate::texture::Texcoord { uv: [fx * fx, fy], texture: 0 });
            }
        }
        for y in 0..n {
            for x in 0..n {
                let v = y * (n + 1) + x;
                m.indices.extend([v, v + 1, v + n + 2, v, v + n + 2, v + n + 1]);
            }
        }
        // Where a point of the surface samples the texture on a level: its triangle's
        // interpolated u, against x squared.
        let slide = |level: &Mesh| {
            let mut worst = 0f32;
            for t in level.indices.chunks_exact(3) {
                let p: Vec<Vec3> = t.iter().map(|&v| Vec3::from_array(level.positions[v as usize])).collect();
                let centre = (p[0] + p[1] + p[2]) / 3.0;
                let u = t.iter().map(|&v| level.texcoords[v as usize].uv[0]).sum::<f32>() / 3.0;
                worst = worst.max((u - centre.x * centre.x).abs());
            }
            worst
        };
        let (textured, _) = chain(m.clone(), 1e-6);
        let (plain, _) = chain(Mesh { texcoords: Vec::new(), ..m }, 1e-6);
        let with_uv = Mesh {
            texcoords: plain[1].mesh.positions.iter().map(|p| crate::texture::Texcoord { uv: [p[0] * p[0], p[1]], texture: 0 }).collect(),
            ..plain[1].mesh.clone()
        };
        assert!(slide(&textured[1].mesh) < slide(&with_uv) / 2.0, "{} against {}", slide(&textured[1].mesh), slide(&with_uv));
        assert!(textured[1].error > 0.0);
    }

    #[test]
    fn a_box_is_too_small_for_a_lod() {
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        let (levels, stats) = chain(m, 1e-6);
        assert_eq!(levels.len(), 1);
        assert_eq!(stats.too_small, 1);
    }
}
