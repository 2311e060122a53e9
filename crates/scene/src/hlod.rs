//! HLODs for interior nodes (occlusion switch sec. 4.1, after Erikson et al. 2001): the children's
//! coarsest representations merged and simplified with meshoptimizer's sloppy simplifier,
//! which merges disjoint parts (a row of tanks becomes one blob) where edge collapse cannot.
//!
//! Error: the sloppy step's absolute error, or the distance measured from its input to its
//! result where larger (vertex clustering drops coplanar parts at no error by the input's
//! planes: [`crate::deviation`]), plus the largest error of the merged inputs, so that a
//! parent's error is never below a child's (errors monotone up the hierarchy).

use crate::limits::{HLOD_MAX_FRACTION, HLOD_MAX_TRIANGLES, LOD_MAX_LEVELS, LOD_MIN_TRIANGLES, LOD_TARGET_RATIO};
use crate::lod::Level;
use crate::mesh::Mesh;

/// Why a group got no HLOD.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoHlod {
    /// The simplifier kept more than HLOD_MAX_FRACTION of the input's triangles.
    NotCoarser,
    /// The simplifier removed everything: parts too small to merge at any coarser size.
    Vanished,
    /// An object under the node reaches outside it (see [`crate::owner`]).
    Open,
}

/// The HLOD of a node whose children's coarsest representations are `parts`, or why there is
/// none: it must have at most HLOD_MAX_FRACTION of the parts' triangles, else drawing the
/// parts costs little more. Aims at LOD_TARGET_RATIO of the input, then at the largest size
/// allowed when the first aim collapses the parts to nothing (small inputs do). `min_error`
/// (> 0) is the smallest error the result may report.
pub fn build(parts: &[&Level], min_error: f32) -> Result<Level, NoHlod> {
    let mut merged = Mesh::default();
    for p in parts {
        merged.append(&p.mesh);
    }
    let input = merged.triangle_count();
    if input == 0 {
        return Err(NoHlod::Vanished);
    }
    let most = (input as f32 * HLOD_MAX_FRACTION) as usize;
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&merged.positions), 12, 0).expect("12-byte vertices");
    let mut result = Err(NoHlod::Vanished);
    for aim in [(input as f32 * LOD_TARGET_RATIO) as usize, most] {
        // meshoptimizer asserts target <= input.
        let target = aim.clamp(1, HLOD_MAX_TRIANGLES as usize).min(input);
        let mut rel = 0.0f32;
        let indices = meshopt::simplify_sloppy(&merged.indices, &adapter, target * 3, 1.0, Some(&mut rel));
        if indices.len() / 3 > most {
            return Err(NoHlod::NotCoarser);
        }
        if !indices.is_empty() {
            result = Ok((indices, rel));
            break;
        }
    }
    let (indices, rel) = result?;
    let scale = meshopt::simplify_scale(&adapter);
    let inputs_error = parts.iter().map(|p| p.error).fold(0.0, f32::max);
    let mesh = merged.sub_mesh(&indices);
    // The sloppy step's own error is by the input's planes; what it dropped within them is
    // measured (crate::deviation).
    let step = crate::deviation::one_sided(&merged, &mesh, rel * scale, crate::deviation::CLUSTERING_STEPS);
    Ok(Level { mesh, error: inputs_error + step.max(min_error) })
}

/// Ends a chain in levels each simplified as an HLOD of the one before alone would be, while
/// that is coarser, up to LOD_MAX_LEVELS or a level of at most LOD_MIN_TRIANGLES (as a chain
/// ends): a mesh stored once for many uses has no neighbour to meet, so the sloppy simplifier
/// may go on where edge collapse with its borders locked stopped paying, and its far uses draw
/// a handful of triangles instead of the chain's last level at a small fraction of a pixel of
/// error.
///
/// The stand-ins start at the first chain level that a stand-in of the level before buys
/// cheaper (the smaller product of error and triangles, as [`crate::lod::chain`] weighs
/// pruning against collapsing) or a whole step coarser (LOD_TARGET_RATIO of its triangles), at
/// a quarter of its error or less (a level's step, one halving of the screen size): a chain
/// step that paid its triangles with a jump of error, as pruning a boiler's tube bank (a
/// thousand triangles at millimetres to four at metres), drew the finer level out to a hundred
/// times the distance. Returns how many of the chain's levels were kept.
pub fn stand_ins(levels: &mut Vec<Level>, min_error: f32) -> usize {
    let cost = |l: &Level| l.error as f64 * l.mesh.triangle_count() as f64;
    let mut next = None;
    for k in 1..levels.len() {
        if let Ok(s) = build(&[&levels[k - 1]], min_error)
            && s.error > levels[k - 1].error
            && !s.mesh.is_empty()
            && (cost(&s) < cost(&levels[k])
                || s.mesh.triangle_count() as f32 <= levels[k - 1].mesh.triangle_count() as f32 * LOD_TARGET_RATIO)
            && s.error <= LOD_TARGET_RATIO * levels[k].error
        {
            levels.truncate(k);
            next = Some(s);
            break;
        }
    }
    let chained = levels.len();
    while levels.len() < LOD_MAX_LEVELS {
        let last = levels.last().expect("level 0");
        let stand_in = match next.take() {
            Some(s) => Ok(s),
            None => build(&[last], min_error),
        };
        match stand_in {
            Ok(s) if s.error > last.error && !s.mesh.is_empty() => {
                let small = s.mesh.triangle_count() <= LOD_MIN_TRIANGLES as usize;
                levels.push(s);
                if small {
                    break;
                }
            }
            _ => break,
        }
    }
    chained
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;
    use glam::Vec3;
    use proptest::prelude::*;

    #[test]
    fn two_spheres_merge_into_a_coarser_hlod_with_larger_error() {
        let sphere = |x: f32| {
            let mut m = Mesh::default();
            shapes::lathe(&mut m, Vec3::new(x, 0.0, 0.0), &shapes::sphere_profile(1.0, 16), 32);
            Level { mesh: m, error: 0.01 * (x + 1.0) }
        };
        let (a, b) = (sphere(0.0), sphere(3.0));
        let h = build(&[&a, &b], 1e-6).expect("an HLOD");
        assert!(h.mesh.triangle_count() as f32 <= HLOD_MAX_FRACTION * (a.mesh.triangle_count() + b.mesh.triangle_count()) as f32);
        assert!(h.error > a.error.max(b.error));
    }

    #[test]
    fn stand_ins_go_on_coarser_while_they_pay() {
        // A part cut from a larger surface: an open pipe whose every vertex lies on a border
        // that edge collapse keeps, so that its chain stops at once.
        let mut m = Mesh::default();
        shapes::tube(&mut m, &[Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0)], 0.5, 256, false);
        let (mut levels, _) = crate::lod::chain(m, 1e-6);
        let chained = stand_ins(&mut levels, 1e-6);
        assert!(levels.len() >= chained + 2, "{chained} levels chained, {} with stand-ins", levels.len());
        for w in levels[chained - 1..].windows(2) {
            assert!(w[1].mesh.triangle_count() as f32 <= HLOD_MAX_FRACTION * w[0].mesh.triangle_count() as f32);
            assert!(w[1].error > w[0].error);
        }
        // They end as a chain does: at a level of a few triangles.
        assert!(levels.last().unwrap().mesh.triangle_count() <= LOD_MIN_TRIANGLES as usize);
    }

    #[test]
    fn a_chain_step_paid_with_a_jump_of_error_is_replaced_by_stand_ins() {
        // A boiler of the plant's catalogue, tessellated as a vendor's part: a casing, a bank
        // of thin tubes and a drum. Some of its chunks' chains pay a step by pruning whole
        // tubes (a thousandfold jump of error); the sloppy simplifier merges them instead.
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::new(6.0, 4.2, 5.0));
        for k in 0..16 {
            let x = 6.0 * (k as f32 + 0.5) / 16.0;
            shapes::cylinder(&mut m, Vec3::new(x, 0.0, -0.3), Vec3::new(x, 4.2, -0.3), 0.12, 120);
        }
        shapes::cylinder(&mut m, Vec3::new(0.0, 4.8, 2.5), Vec3::new(6.0, 4.8, 2.5), 0.6, 288);
        let chunks = crate::chunk::split(&m, crate::chunk::SplitOptions { max_triangles: 4096, loose: 0.7 });
        let mut jumps_replaced = 0;
        for c in chunks.meshes {
            let (chain, _) = crate::lod::chain(c, 1e-6);
            let mut levels = chain.clone();
            let kept = stand_ins(&mut levels, 1e-6);
            assert!(levels[..kept].iter().zip(&chain).all(|(a, b)| a.error == b.error), "the chain's first levels stay");
            // Below every level of the chain, a level at least as coarse and as exact as the
            // chain's next: a level at a 16th of its error counts as a jump replaced.
            let below = |w: &[Level], within: f32| {
                levels.iter().any(|l| l.mesh.triangle_count() < w[0].mesh.triangle_count() && l.error <= w[1].error * within)
            };
            for w in chain.windows(2) {
                assert!(below(w, 1.0), "{} triangles at {} m", w[1].mesh.triangle_count(), w[1].error);
                jumps_replaced += usize::from(below(w, 1.0 / 16.0));
            }
        }
        assert!(jumps_replaced > 0);
    }

    proptest! {
        /// On any bumpy sheet, tiny or huge, near the origin or far from it: stand-ins never
        /// fail, each keeps at most half the triangles of the one before at a larger finite
        /// error, and a chain stays within LOD_MAX_LEVELS.
        #[test]
        fn stand_ins_of_any_sheet_at_any_scale_are_coarser(
            (nx, nz) in (1u32..40, 1u32..40),
            bumps in prop::collection::vec(-1.0f32..1.0, 1681),
            scale in prop::sample::select(vec![1e-6f32, 1.0, 1e6]),
            offset in prop::sample::select(vec![0.0f32, 1e4, 1e6]),
        ) {
            let mut m = Mesh::default();
            shapes::grid_plane(&mut m, Vec3::ZERO, Vec3::ONE, nx, nz);
            for (k, p) in m.positions.iter_mut().enumerate() {
                *p = [p[0] * scale + offset, bumps[k % bumps.len()] * 0.1 * scale, p[2] * scale];
            }
            let mut levels = vec![Level { mesh: m, error: 0.0 }];
            stand_ins(&mut levels, 1e-7 * scale);
            prop_assert!(levels.len() <= LOD_MAX_LEVELS);
            for w in levels.windows(2) {
                prop_assert!(w[1].mesh.triangle_count() as f32 <= HLOD_MAX_FRACTION * w[0].mesh.triangle_count() as f32);
                prop_assert!(w[1].error > w[0].error && w[1].error.is_finite());
            }
        }
    }

    #[test]
    fn an_hlod_of_coplanar_tiles_reports_the_distance_to_what_it_dropped() {
        // A game level's ground: a 24-by-24 grid of separate 5 m tiles in one plane, two triangles each.
        // Vertex clustering drops tiles at no error by their common plane; the level's error
        // must reach every tile's centre that is left without a surface nearby.
        let mut m = Mesh::default();
        for (i, j) in (0..24).flat_map(|i| (0..24).map(move |j| (i as f32 * 5.0, j as f32 * 5.0))) {
            let n = m.positions.len() as u32;
            m.positions.extend([[i, 0.0, j], [i + 5.0, 0.0, j], [i + 5.0, 0.0, j + 5.0], [i, 0.0, j + 5.0]]);
            m.indices.extend([n, n + 2, n + 1, n, n + 3, n + 2]);
        }
        let hlod = build(&[&Level { mesh: m.clone(), error: 0.0 }], 1e-6).expect("an HLOD");
        let result: Vec<[Vec3; 3]> =
            hlod.mesh.indices.chunks_exact(3).map(|t| [0, 1, 2].map(|k| Vec3::from(hlod.mesh.positions[t[k] as usize]))).collect();
        // Each tile's centre (its first triangle's corners 0 and 2) against the result, by brute force over points of the result's
        // triangles (a barycentric grid of 16 steps a side each: within a fraction of a tile).
        let points: Vec<Vec3> = result
            .iter()
            .flat_map(|t| {
                (0..=16).flat_map(move |a| {
                    (0..=16 - a).map(move |b| t[0] + (t[1] - t[0]) * (a as f32 / 16.0) + (t[2] - t[0]) * (b as f32 / 16.0))
                })
            })
            .collect();
        let farthest = m
            .indices
            .chunks_exact(6)
            .map(|q| (Vec3::from(m.positions[q[0] as usize]) + Vec3::from(m.positions[q[1] as usize])) / 2.0)
            .map(|c| points.iter().map(|p| p.distance(c)).fold(f32::INFINITY, f32::min))
            .fold(0.0, f32::max);
        let slack = result.iter().map(|t| (t[1] - t[0]).length().max((t[2] - t[0]).length())).fold(0.0, f32::max) / 16.0;
        assert!(hlod.error + slack >= farthest, "error {} against a tile centre {farthest} from the result", hlod.error);
        assert!(farthest > 1.0, "the sloppy simplifier dropped no tile: the test tests nothing ({farthest})");
    }

    #[test]
    fn no_hlod_from_nothing() {
        assert_eq!(build(&[], 1e-6).unwrap_err(), NoHlod::Vanished);
    }
}
