//! Fins: two triangles on the same three vertices, wound opposite ways, that simplification
//! made along the surface it kept.
//!
//! Given a large group, meshoptimizer's simplifier can fold a fan of slivers (at a lathe
//! sphere's pole) into such a pair: a sliver lying along the surface, its edges then used
//! twice, which a cut draws. Pairs are also what a fin is not: a model's own two-sided sheets
//! (the triangles simplified hold the pair already), and a thin part (a pipe, a flange) that
//! simplification flattened into a two-sided sheet, which is that part at that level and
//! reaches away from the rest of the surface. So a pair is a fin only where its source has no
//! such pair and each of its corners lies within the group's error of the rest: dropping it
//! then takes no point further from the surface than the error allows. Both triangles go: a
//! pair uses each of its edges once each way, so the surface around it stays as closed as it
//! was; only where the fold left the pair covering a hole (the surface around bounds the
//! pair's triangle) does the one that fills the hole stay.

use crate::mesh::closest_on_triangle;
use glam::Vec3;
use std::collections::HashSet;

/// A triangle's vertices in ascending order, and whether its winding is the rotation of
/// that order (false: the opposite winding).
fn key(t: [u32; 3]) -> ([u32; 3], bool) {
    let r = t.iter().enumerate().min_by_key(|p| p.1).map_or(0, |p| p.0);
    let [a, b, c] = [t[r], t[(r + 1) % 3], t[(r + 2) % 3]];
    ([a, b.min(c), b.max(c)], b < c)
}

fn edges(t: [u32; 3]) -> [(u32, u32); 3] {
    [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
}

/// Vertex sets on which `triangles` hold both windings.
fn pairs(triangles: &[[u32; 3]]) -> HashSet<[u32; 3]> {
    let mut keys: Vec<([u32; 3], bool)> = triangles.iter().map(|&t| key(t)).collect();
    keys.sort_unstable();
    keys.windows(2).filter(|w| w[0].0 == w[1].0 && w[0].1 != w[1].1).map(|w| w[0].0).collect()
}

/// The fins among `made`, the triangles simplification made of `source`'s (a closure: it is
/// read only when `made` holds a pair at all) within `error` of them: their indices in `made`.
pub fn fins(made: &[[u32; 3]], source: impl FnOnce() -> Vec<[u32; 3]>, positions: &[[f32; 3]], error: f32) -> Vec<usize> {
    let candidates = pairs(made);
    if candidates.is_empty() {
        return Vec::new();
    }
    let source = source();
    let own = pairs(&source);
    let is_pair = |t: [u32; 3]| {
        let k = key(t).0;
        candidates.contains(&k) && !own.contains(&k)
    };
    let rest: Vec<[u32; 3]> = made.iter().copied().filter(|&t| !is_pair(t)).collect();
    let at = |v: u32| Vec3::from(positions[v as usize]);
    // A corner the rest uses lies on it; only the others are looked for.
    let used: HashSet<u32> = rest.iter().flatten().copied().collect();
    let near = |v: u32| {
        used.contains(&v) || rest.iter().any(|t| closest_on_triangle(at(v), at(t[0]), at(t[1]), at(t[2])).distance(at(v)) <= error)
    };
    // A directed edge of the rest without its reverse there is a hole the pair covers, unless
    // the source has it without its reverse too (the group's locked border).
    let rest_edges: HashSet<(u32, u32)> = rest.iter().flat_map(|&t| edges(t)).collect();
    let source_edges: HashSet<(u32, u32)> = source.iter().flat_map(|&t| edges(t)).collect();
    let border = |(a, b): (u32, u32)| source_edges.contains(&(a, b)) && !source_edges.contains(&(b, a));
    let fills =
        |t: [u32; 3]| edges(t).iter().any(|&(a, b)| rest_edges.contains(&(b, a)) && !rest_edges.contains(&(a, b)) && !border((b, a)));
    (0..made.len()).filter(|&i| is_pair(made[i]) && made[i].iter().all(|&v| near(v)) && !fills(made[i])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed tetrahedron (outward winding) on vertices 0-3.
    const TETRA: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
    /// Its corners, and four vertices 4-7 far from it.
    const TETRA_AT: [[f32; 3]; 8] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [5.0, 5.0, 5.0],
        [6.0, 5.0, 5.0],
        [5.0, 6.0, 5.0],
        [6.0, 6.0, 5.0],
    ];

    /// A closed octahedron on vertices 0-5 (+x, -x, +y, -y, +z, -z).
    const OCTA: [[u32; 3]; 8] = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    /// Its corners; 6 just off its face 0-2-4 (1e-3 out), 7 far off it.
    const OCTA_AT: [[f32; 3]; 8] = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [0.3339, 0.3339, 0.3339],
        [2.0, 2.0, 0.0],
    ];

    /// Every directed edge once, its reverse once.
    fn closed(triangles: &[[u32; 3]]) -> bool {
        let all: Vec<(u32, u32)> = triangles.iter().flat_map(|&t| edges(t)).collect();
        all.iter().all(|&(a, b)| all.iter().filter(|&&e| e == (a, b)).count() == 1 && all.contains(&(b, a)))
    }

    fn without(made: &[[u32; 3]], drop: &[usize]) -> Vec<[u32; 3]> {
        made.iter().enumerate().filter(|(i, _)| !drop.contains(i)).map(|p| *p.1).collect()
    }

    #[test]
    fn a_fin_along_a_closed_surface_goes() {
        // A pair through the octahedron's middle (+x, -x, +y) on three of its corners, and a
        // sliver on its edge 0-2 out to a point just off its face.
        for (fin, error) in [([[0, 1, 2], [1, 0, 2]], 0.0), ([[0, 2, 6], [2, 0, 6]], 1e-2)] {
            let made = [OCTA.as_slice(), &fin].concat();
            assert!(!closed(&made));
            let drop = fins(&made, || OCTA.to_vec(), &OCTA_AT, error);
            assert_eq!(drop, vec![8, 9], "{fin:?}");
            assert!(closed(&without(&made, &drop)));
        }
        // The sliver further off than the error: a part of the surface at that level.
        let made = [OCTA.as_slice(), &[[0, 2, 6], [2, 0, 6]]].concat();
        assert!(fins(&made, || OCTA.to_vec(), &OCTA_AT, 1e-4).is_empty());
    }

    #[test]
    fn a_flattened_part_stays() {
        // A flange flattened into a two-sided sheet on the octahedron's edge 0-2, out to a
        // vertex far off it; and a free two-sided ribbon.
        let flange = [[0, 2, 7], [2, 0, 7]];
        let made = [OCTA.as_slice(), &flange].concat();
        assert!(fins(&made, || OCTA.to_vec(), &OCTA_AT, 1e-2).is_empty());
        let ribbon = [[4, 5, 6], [4, 6, 5], [5, 7, 6], [5, 6, 7]];
        let made = [TETRA.as_slice(), &ribbon].concat();
        assert!(fins(&made, || TETRA.to_vec(), &TETRA_AT, 1e-2).is_empty());
    }

    #[test]
    fn a_pair_over_a_hole_keeps_the_triangle_that_fills_it() {
        // The tetrahedron's face 1-2-3 folded into both windings: 1-2-3 closes it, 1-3-2 is
        // the fin (written in either order and rotation).
        for pair in [[[1, 2, 3], [3, 2, 1]], [[2, 1, 3], [2, 3, 1]]] {
            let made = [&TETRA[..2], &TETRA[3..], &pair].concat();
            let drop = fins(&made, || TETRA.to_vec(), &TETRA_AT, 0.0);
            assert_eq!(drop.len(), 1, "{pair:?}");
            assert!(closed(&without(&made, &drop)), "{pair:?}");
        }
    }

    #[test]
    fn a_pair_the_source_has_stays() {
        // A two-sided sheet of the model: the source holds the pair, so simplification did
        // not make it.
        let sheet = [[0, 1, 2], [0, 2, 1]];
        assert!(fins(&sheet, || sheet.to_vec(), &TETRA_AT, 1.0).is_empty());
        // Triangles on the same vertices wound the same way are no pair.
        assert!(fins(&[[0, 1, 2], [1, 2, 0]], || panic!("read without a pair"), &TETRA_AT, 1.0).is_empty());
    }

    #[test]
    fn a_fin_at_a_locked_border_goes() {
        // An open group: the tetrahedron less face 2-0-3, whose edges are the border the
        // source and the simplified group share (the neighbouring group holds that face); a
        // pair on the border's three corners fills nothing of this group's.
        let open = &TETRA[..3];
        let made = [open, &[[2, 0, 3], [0, 2, 3]]].concat();
        assert_eq!(fins(&made, || open.to_vec(), &TETRA_AT, 0.0), vec![3, 4]);
    }
}
