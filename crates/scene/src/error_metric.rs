//! Object-space error projected to pixels, and LOD selection against tau (occlusion switch sec. 4.1:
//! "we project this error metric to the screen space ... and select the lowest resolution LOD
//! or HLOD that satisfies the error bound").
//!
//! An error `e` (world units) at distance `d` from the eye covers at most `e * f / d` pixels,
//! `f` the focal length in pixels. Taking `d` as the distance from the eye to the node's box
//! (never more than the distance to any point of the geometry) makes this an upper bound:
//! conservative. Computed in f64 from an eye in scene-local f64 coordinates.

use crate::aabb::Aabb;
use crate::format::{NodeId, NodeRecord};
use glam::DVec3;

/// Distance from `eye` to the closed box `b`, 0 inside.
pub fn distance_to_box(eye: DVec3, b: &Aabb) -> f64 {
    let lo = b.min.as_dvec3();
    let hi = b.max.as_dvec3();
    (lo - eye).max(eye - hi).max(DVec3::ZERO).length()
}

/// Pixels of error of `error` (world units, >= 0) on geometry inside `b` seen from `eye` with
/// focal length `focal_px`. 0 for error 0; +inf when the eye is in or on the box (must
/// refine). Never NaN for finite inputs.
pub fn projected_error_px(error: f32, b: &Aabb, eye: DVec3, focal_px: f64) -> f64 {
    if error <= 0.0 {
        return 0.0;
    }
    let d = distance_to_box(eye, b);
    if d <= 0.0 {
        return f64::INFINITY;
    }
    // error * focal can overflow to inf for absurd inputs; inf means refine, which is safe.
    error as f64 * focal_px / d
}

/// The coarsest LOD of BVH node `node` whose projected error is at most `tau` pixels, or
/// `None` when none is fine enough (a group must be refined). `nodes` is the node table.
pub fn select_lod(nodes: &[NodeRecord], node: NodeId, eye: DVec3, focal_px: f64, tau: f64) -> Option<NodeId> {
    let n = &nodes[node as usize];
    let b = n.aabb();
    n.lods().rev().find(|&l| projected_error_px(nodes[l as usize].error, &b, eye, focal_px) <= tau)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use proptest::prelude::*;

    fn unit() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    #[test]
    fn error_over_distance_times_focal() {
        // Eye 9 units in front of the face x = 1: d = 9, 0.5 * 900 / 9 = 50 px.
        let px = projected_error_px(0.5, &unit(), DVec3::new(10.0, 0.5, 0.5), 900.0);
        assert!((px - 50.0).abs() < 1e-9);
    }

    #[test]
    fn camera_at_distance_zero_must_refine_without_nan() {
        for eye in [DVec3::splat(0.5), DVec3::new(1.0, 0.5, 0.5), DVec3::ZERO] {
            assert_eq!(projected_error_px(0.1, &unit(), eye, 1000.0), f64::INFINITY);
            assert_eq!(projected_error_px(0.0, &unit(), eye, 1000.0), 0.0);
        }
    }

    #[test]
    fn zero_thickness_box_and_far_offsets() {
        let flat = Aabb::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 1.0));
        assert_eq!(projected_error_px(1.0, &flat, DVec3::new(0.5, 0.0, 0.5), 1000.0), f64::INFINITY);
        let px = projected_error_px(1.0, &flat, DVec3::new(0.5, 1e7, 0.5), 1000.0);
        assert!((px - 1e-4).abs() < 1e-12);
    }

    proptest! {
        /// Never NaN; never increases with distance along a ray away from the box; grows
        /// linearly with the error.
        #[test]
        fn monotone_in_distance_and_error(
            x in -1e7f64..1e7, y in -1e7f64..1e7, z in -1e7f64..1e7,
            t in 1.0f64..1e3, e in 0.0f32..1e3, f in 1.0f64..1e5,
        ) {
            let eye = DVec3::new(x, y, z);
            let far = DVec3::splat(0.5) + (eye - DVec3::splat(0.5)) * t;
            let near_px = projected_error_px(e, &unit(), eye, f);
            let far_px = projected_error_px(e, &unit(), far, f);
            prop_assert!(!near_px.is_nan() && !far_px.is_nan());
            prop_assert!(far_px <= near_px * (1.0 + 1e-12));
            let twice = projected_error_px(e * 2.0, &unit(), eye, f);
            prop_assert!(twice >= near_px);
        }

        /// The selected LOD satisfies tau and the next coarser one does not.
        #[test]
        fn selection_picks_the_coarsest_that_fits(d in 0.0f64..1e4, tau in 0.0f64..50.0) {
            let mut nodes = vec![NodeRecord { bbox_min: [0.0; 3], bbox_max: [1.0; 3], first_lod: 1, lod_count: 4, ..bytemuck::Zeroable::zeroed() }];
            for e in [0.0f32, 0.01, 0.1, 1.0] {
                nodes.push(NodeRecord { error: e, bbox_min: [0.0; 3], bbox_max: [1.0; 3], ..bytemuck::Zeroable::zeroed() });
            }
            let eye = DVec3::new(1.0 + d, 0.5, 0.5);
            let px = |l: u32| projected_error_px(nodes[l as usize].error, &unit(), eye, 1000.0);
            let got = select_lod(&nodes, 0, eye, 1000.0, tau).expect("level 0 has error 0");
            prop_assert!(px(got) <= tau);
            if got < 4 {
                prop_assert!(px(got + 1) > tau);
            }
        }
    }
}
