//! Placement: objects in f64 world coordinates → one scene origin and scene-local f32.
//!
//! Real models stand far from their file's origin (site coordinates of a plant, a ship yard or
//! a city: 1e6-1e9 units out), where f32's spacing is 0.06-64 units. Every reader keeps
//! positions as f32 in the object's own frame plus an f64 placement (a glTF node's world
//! matrix composed in f64, a PLY or OBJ file's anchor, a generator's offset); only here, once
//! the origin is known, does each vertex go to f32, as `placement · p − origin` evaluated in
//! f64. The scene file stores the origin (see [`crate::format::Header::origin`]).
//!
//! The origin is the centre of the world bounds rounded to whole units: a model moved by a
//! whole number of units gets the same scene-local coordinates, bit for bit, as at the
//! origin, so it builds into the same node table and renders the same frames.

use crate::mesh::Object;
use glam::{DAffine3, DVec3, Vec3};
use rayon::prelude::*;

/// The scene origin for world bounds `min..max`: their centre rounded to whole units (0 for
/// empty bounds).
pub fn origin_of(min: DVec3, max: DVec3) -> DVec3 {
    if min.cmpgt(max).any() {
        return DVec3::ZERO;
    }
    // Halves first: the sum of two coordinates near f64::MAX would overflow.
    (min * 0.5 + max * 0.5).round()
}

/// An anchor for positions given in f64 (PLY `double`, OBJ): [`origin_of`] their bounds.
pub fn anchor(points: impl Iterator<Item = DVec3>) -> DVec3 {
    let (min, max) = bounds(points);
    origin_of(min, max)
}

/// `points` as f32 relative to `anchor` (the placement that puts them back is a translation
/// by `anchor`).
pub fn relative(points: &[[f64; 3]], anchor: DVec3) -> Vec<[f32; 3]> {
    points.iter().map(|p| (DVec3::from_array(*p) - anchor).as_vec3().to_array()).collect()
}

/// Moves every object into scene-local coordinates around the origin of their world bounds;
/// returns the objects (placements now the identity) and the origin.
pub fn place(mut objects: Vec<Object>) -> (Vec<Object>, DVec3) {
    let (min, max) = world_bounds(&objects);
    let origin = origin_of(min, max);
    to_local(&mut objects, origin);
    (objects, origin)
}

/// Bounds of the objects' finite world positions (placements applied).
pub fn world_bounds(objects: &[Object]) -> (DVec3, DVec3) {
    objects
        .par_iter()
        .map(|o| bounds(o.mesh.positions.iter().map(|p| o.placement.transform_point3(Vec3::from_array(*p).as_dvec3()))))
        .reduce(|| bounds(std::iter::empty()), |(a, b), (c, d)| (a.min(c), b.max(d)))
}

/// Moves objects into scene-local coordinates around `origin` (placements become the
/// identity). A position whose local coordinate overflows f32 becomes infinite, which the
/// clean-up reports by object.
pub fn to_local(objects: &mut [Object], origin: DVec3) {
    objects.par_iter_mut().for_each(|o| {
        let to_local = DAffine3::from_translation(-origin) * o.placement;
        if to_local != DAffine3::IDENTITY {
            for p in &mut o.mesh.positions {
                // Translation last and in f64: `placement · p` first, then `− origin`.
                let w = o.placement.transform_point3(Vec3::from_array(*p).as_dvec3());
                *p = (w - origin).as_vec3().to_array();
            }
        }
        o.placement = DAffine3::IDENTITY;
    });
}

/// Bounds of the finite points (a non-finite one is an error the clean-up reports by object).
fn bounds(points: impl Iterator<Item = DVec3>) -> (DVec3, DVec3) {
    points.filter(|p| p.is_finite()).fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;

    fn object(points: &[[f32; 3]], placement: DAffine3) -> Object {
        Object { name: "o".into(), mesh: Mesh { positions: points.to_vec(), indices: vec![0, 1, 2], colors: Vec::new() }, placement }
    }

    #[test]
    fn origin_is_the_rounded_centre() {
        assert_eq!(origin_of(DVec3::new(-1.0, 2.0, 10.0), DVec3::new(1.0, 3.0, 13.2)), DVec3::new(0.0, 3.0, 12.0));
        assert_eq!(origin_of(DVec3::INFINITY, DVec3::NEG_INFINITY), DVec3::ZERO);
        assert_eq!(origin_of(DVec3::splat(f64::MAX), DVec3::splat(f64::MAX)), DVec3::splat(f64::MAX));
        let (min, max) = bounds([DVec3::ONE, DVec3::NAN, DVec3::INFINITY, DVec3::splat(3.0)].into_iter());
        assert_eq!(origin_of(min, max), DVec3::splat(2.0));
    }

    #[test]
    fn a_whole_unit_shift_gives_the_same_local_coordinates() {
        // Coordinates with bits far below f32's spacing at 1e7 (1 unit). `placement · p` is
        // exact in f64 when p is a multiple of f64's spacing at the shift (2^-29 at 1e7: any f32
        // of magnitude 2^-6 or more), and then so is every later step.
        let pts = [[0.123_456_7, -3.000_001, 17.25], [5.5, 0.031_25, -2.0e-2], [-7.75, 0.0, 3.3]];
        let (near, o0) = place(vec![object(&pts, DAffine3::IDENTITY)]);
        let t = DVec3::new(1e7, 1e7, -1e7);
        let (far, o1) = place(vec![object(&pts, DAffine3::from_translation(t))]);
        assert_eq!(o1 - o0, t);
        assert_eq!(far[0].mesh.positions, near[0].mesh.positions);
        assert_eq!(far[0].placement, DAffine3::IDENTITY);
        // At 1e9 f64's spacing is 2^-23: small coordinates may move by one f32 step, no more.
        let t = DVec3::new(-1e9, 1e9, 1e9);
        let (far, o1) = place(vec![object(&pts, DAffine3::from_translation(t))]);
        assert_eq!(o1 - o0, t);
        for (a, b) in far[0].mesh.positions.iter().zip(&near[0].mesh.positions) {
            for (x, y) in a.iter().zip(b) {
                assert!((x - y).abs() <= y.abs().max(1.0) * f32::EPSILON, "{a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn f32_world_positions_at_1e7_would_collapse_a_small_mesh() {
        // The reason for this module: the same triangle stored in world f32 is degenerate.
        let pts = [[0.1f32, 0.0, 0.0], [0.4, 0.0, 0.0], [0.1, 0.3, 0.0]];
        let world: Vec<Vec3> = pts.iter().map(|p| Vec3::from_array(*p) + Vec3::splat(1e7)).collect();
        assert_eq!((world[1] - world[0]).cross(world[2] - world[0]).length_squared(), 0.0);
        let (placed, _) = place(vec![object(&pts, DAffine3::from_translation(DVec3::splat(1e7)))]);
        let v: Vec<Vec3> = placed[0].mesh.positions.iter().map(|p| Vec3::from_array(*p)).collect();
        assert!((v[1] - v[0]).cross(v[2] - v[0]).length() > 0.08);
    }

    #[test]
    fn anchored_keeps_f64_precision() {
        let pts = [[4_512_345.678_9, -0.5, 1e9 + 0.25], [4_512_346.678_9, 0.5, 1e9 - 0.25]];
        let a = anchor(pts.iter().map(|p| DVec3::from_array(*p)));
        assert_eq!(a, DVec3::new(4_512_346.0, 0.0, 1e9));
        for (l, p) in relative(&pts, a).iter().zip(&pts) {
            let back = a + Vec3::from_array(*l).as_dvec3();
            assert!((back - DVec3::from_array(*p)).abs().max_element() < 1e-7, "{back} vs {p:?}");
        }
    }
}
