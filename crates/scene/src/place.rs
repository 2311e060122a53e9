//! Placement: objects in f64 world coordinates → one scene origin and scene-local f32.
//!
//! Real models stand far from their file's origin (site coordinates of a plant, a ship yard or
//! a city: 1e6-1e9 units out), where f32's spacing is 0.06-64 units. Every reader keeps
//! positions as f32 in the object's own frame plus an f64 placement at the model's own scale
//! and a whole-unit anchor (a glTF node's world matrix composed in f64 with its whole units
//! taken out at each node, a PLY or OBJ file's anchor, a generator's offset); only here, once
//! the origin is known, does each vertex go to f32, as `placement · p + (anchor − origin)`
//! evaluated in f64. The scene file stores the origin (see [`crate::format::Header::origin`]).
//!
//! The origin is the centre of the world bounds rounded to whole units. Bounds are taken
//! relative to an anchor and `anchor − origin` is a difference of whole numbers, so nothing is
//! formed at the model's distance from the file's origin: a model moved by a whole number of
//! units gets the same scene-local coordinates, bit for bit, as at the origin, whatever its own
//! transforms, and so builds into the same node table and renders the same frames. (Forming
//! `placement · p` at 1e7 first rounds to f64's spacing there, 1.9e-9, an occasional f32
//! rounding of the local coordinate then flips, and the simplifier builds another mesh.)

use crate::mesh::Object;
use glam::{DAffine3, DMat4, DVec3};
use rayon::prelude::*;

/// Bounds of world positions as `anchor + min .. anchor + max`, `anchor` whole units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub anchor: DVec3,
    pub min: DVec3,
    pub max: DVec3,
}

impl Bounds {
    /// Bounds given in world coordinates of small magnitude (a generator's).
    pub fn world(min: DVec3, max: DVec3) -> Bounds {
        Bounds { anchor: DVec3::ZERO, min, max }
    }

    /// The scene origin: the centre rounded to whole units (the anchor for empty bounds).
    pub fn origin(&self) -> DVec3 {
        self.anchor + origin_of(self.min, self.max)
    }
}

/// The centre of `min..max` rounded to whole units (0 for empty bounds).
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

/// `points` as f32 relative to `anchor` (the object's anchor; its placement the identity).
pub fn relative(points: &[[f64; 3]], anchor: DVec3) -> Vec<[f32; 3]> {
    points.iter().map(|p| (DVec3::from_array(*p) - anchor).as_vec3().to_array()).collect()
}

/// Splits `m` into whole units of translation and the rest: `m = T(whole) · rest`, `rest`'s
/// translation within half a unit of zero. Exact: `t − round(t)` is a difference of nearby
/// f64s.
pub fn split(m: DMat4) -> (DVec3, DMat4) {
    let whole = m.w_axis.truncate().round();
    let mut rest = m;
    rest.w_axis -= whole.extend(0.0);
    (whole, rest)
}

/// Moves every object into scene-local coordinates around the origin of their world bounds;
/// returns the objects (placements now the identity) and the origin.
pub fn place(mut objects: Vec<Object>) -> (Vec<Object>, DVec3) {
    let origin = world_bounds(&objects).origin();
    to_local(&mut objects, origin);
    (objects, origin)
}

/// Bounds of the objects' finite world positions, relative to the first object's anchor.
pub fn world_bounds(objects: &[Object]) -> Bounds {
    let anchor = objects.first().map_or(DVec3::ZERO, |o| o.anchor);
    let (min, max) = objects
        .par_iter()
        .map(|o| {
            let shift = o.anchor - anchor;
            bounds(o.mesh.positions.iter().map(|p| o.placement.transform_point3(glam::Vec3::from_array(*p).as_dvec3()) + shift))
        })
        .reduce(|| bounds(std::iter::empty()), |(a, b), (c, d)| (a.min(c), b.max(d)));
    Bounds { anchor, min, max }
}

/// Moves objects into scene-local coordinates around `origin` (placements become the
/// identity). A position whose local coordinate overflows f32 becomes infinite, which the
/// clean-up reports by object.
pub fn to_local(objects: &mut [Object], origin: DVec3) {
    objects.par_iter_mut().for_each(|o| {
        // Whole units: exact.
        let shift = o.anchor - origin;
        if o.placement != DAffine3::IDENTITY || shift != DVec3::ZERO {
            for p in &mut o.mesh.positions {
                let local = o.placement.transform_point3(glam::Vec3::from_array(*p).as_dvec3());
                *p = (local + shift).as_vec3().to_array();
            }
            crate::normal::transform(&mut o.mesh.normals, o.placement.matrix3);
            // A mirroring placement turns counter-clockwise into clockwise: the front faces of
            // a glTF node whose world matrix has a negative determinant wind clockwise (glTF
            // 2.0 sec. 3.7.4), so its triangles are turned back to counter-clockwise.
            if o.placement.matrix3.determinant() < 0.0 {
                o.mesh.indices.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
            }
        }
        (o.placement, o.anchor) = (DAffine3::IDENTITY, DVec3::ZERO);
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
    use glam::Vec3;

    fn object(points: &[[f32; 3]], anchor: DVec3, placement: DAffine3) -> Object {
        Object::placed("o", Mesh { positions: points.to_vec(), indices: vec![0, 1, 2], ..Default::default() }, anchor, placement)
    }

    /// A mirroring placement keeps front faces in front: the triangle turned back to
    /// counter-clockwise, and its normals outward.
    #[test]
    fn a_mirror_keeps_front_faces_in_front() {
        let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let face = |o: &Object| {
            let p = |k: usize| Vec3::from(o.mesh.positions[o.mesh.indices[k] as usize]);
            (p(1) - p(0)).cross(p(2) - p(0)).normalize()
        };
        let mirrors = DAffine3::from_scale(DVec3::new(-1.0, 0.5, 2.0)) * DAffine3::from_rotation_y(0.4);
        for placement in [mirrors, DAffine3::from_rotation_x(3.0)] {
            let mut o = object(&pts, DVec3::ZERO, placement);
            o.mesh.normals = vec![crate::normal::encode(Vec3::Z); 3];
            // The front face's normal (+z) under the placement, by its inverse transpose.
            let want = (placement.matrix3.inverse().transpose() * DVec3::Z).as_vec3().normalize();
            to_local(std::slice::from_mut(&mut o), DVec3::ZERO);
            assert!(face(&o).dot(want) > 0.999, "{placement:?}: the face turns {}", face(&o));
            assert!(crate::normal::decode(o.mesh.normals[0]).dot(want) > 0.999);
        }
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
    fn a_whole_unit_shift_gives_the_same_local_coordinates_whatever_the_transform() {
        // A placement with a rotation, a non-uniform scale and fractional offsets: composed at
        // 1e7 (f64 spacing 1.9e-9) its products would round differently from those at the
        // origin; kept at the model's scale with the shift in the anchor they are the same.
        let pts = [[0.123_456_7, -3.000_001, 17.25], [5.5, 0.031_25, -2.0e-2], [-7.75, 0.0, 3.3]];
        let m = DAffine3::from_scale_rotation_translation(
            DVec3::new(0.3048, 1.7, 0.01),
            glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.9),
            DVec3::new(0.123_456_789, -17.000_000_1, 3.333_333_333_333_7),
        );
        let (near, o0) = place(vec![object(&pts, DVec3::ZERO, m), object(&pts, DVec3::new(3.0, 0.0, -2.0), m)]);
        for t in [DVec3::new(1e7, 1e7, -1e7), DVec3::new(-1e9, 1e9, 1e9), DVec3::new(4_503_599_627_370_496.0, 0.0, -1.0)] {
            let (far, o1) = place(vec![object(&pts, t, m), object(&pts, t + DVec3::new(3.0, 0.0, -2.0), m)]);
            assert_eq!(o1 - o0, t);
            for (a, b) in far.iter().zip(&near) {
                assert_eq!(a.mesh.positions, b.mesh.positions, "shift {t}");
                assert_eq!((a.placement, a.anchor), (DAffine3::IDENTITY, DVec3::ZERO));
            }
        }
    }

    #[test]
    fn split_takes_out_whole_units_exactly() {
        let m = DMat4::from_scale_rotation_translation(
            DVec3::splat(2.5),
            glam::DQuat::from_rotation_y(0.7),
            DVec3::new(1e7 + 0.625, -3.5, 0.25),
        );
        let (whole, rest) = split(m);
        assert_eq!(whole, DVec3::new(1e7 + 1.0, -4.0, 0.0));
        assert_eq!(rest.w_axis.truncate(), DVec3::new(-0.375, 0.5, 0.25));
        assert_eq!(rest.x_axis, m.x_axis);
    }

    #[test]
    fn f32_world_positions_at_1e7_would_collapse_a_small_mesh() {
        // The reason for this module: the same triangle stored in world f32 is degenerate.
        let pts = [[0.1f32, 0.0, 0.0], [0.4, 0.0, 0.0], [0.1, 0.3, 0.0]];
        let world: Vec<Vec3> = pts.iter().map(|p| Vec3::from_array(*p) + Vec3::splat(1e7)).collect();
        assert_eq!((world[1] - world[0]).cross(world[2] - world[0]).length_squared(), 0.0);
        let (placed, _) = place(vec![object(&pts, DVec3::splat(1e7), DAffine3::IDENTITY)]);
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
