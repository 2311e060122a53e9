//! Object-space error projected to pixels, and LOD selection against tau (occlusion switch sec. 4.1:
//! "we project this error metric to the screen space ... and select the lowest resolution LOD
//! or HLOD that satisfies the error bound").
//!
//! An error `e` (world units) at distance `d` from the eye covers at most `e * f / d` pixels,
//! `f` the focal length in pixels. Taking `d` as the distance from the eye to the node's box
//! (never more than the distance to any point of the geometry) makes this an upper bound:
//! conservative. Computed in f64 from an eye in scene-local f64 coordinates.

use crate::aabb::Aabb;
use crate::format::{Cut, ErrorBound, NodeId, NodeKind, NodeRecord};
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

/// How much a group's projected error grows with its size on screen: the error projected from
/// the nearest point of its sphere (Yoon 2003 sec. 6.3.1), at distance `d`, is weighed by
/// `1 + SIZE_WEIGHT * r / d`. The error bounds how far a simplified group's surface moves, not
/// how its flat-shaded faces turn; a turned face changes its colour as much near as far, over
/// every pixel the group covers, so a group large on screen costs the image more than its
/// projected error says. The weight only refines (conservative), and it grows with the radius
/// and with nearness, as the distance does: a sphere that encloses another with an error at
/// least as large still projects to at least as many pixels from every eye, so a cut stays
/// consistent. The weight takes fewer triangles for the same PSNR on the plant and pops less;
/// projecting from nearer than the nearest point instead left groups near the eye never
/// simplified.
/// docs/measurements/2026-12-05-cluster-hierarchy-size-on-screen.md, "How much a group's size on screen counts"
pub const SIZE_WEIGHT: f64 = 11.0;

impl ErrorBound {
    /// The most pixels `error` covers anywhere in the sphere, measured from its nearest point
    /// and weighed by its size on screen ([`SIZE_WEIGHT`]), +inf with the eye inside. Larger
    /// for a sphere that encloses this one with an error at least as large, from every eye:
    /// what keeps a cut consistent.
    pub fn px(&self, eye: DVec3, focal_px: f64) -> f64 {
        if self.error <= 0.0 {
            return 0.0;
        }
        let d = (DVec3::from(self.center.map(f64::from)) - eye).length() - self.radius as f64;
        if d <= 0.0 {
            return f64::INFINITY;
        }
        self.error as f64 * focal_px / d * (1.0 + SIZE_WEIGHT * self.radius as f64 / d)
    }

    /// The fewest pixels `error` covers anywhere in the sphere (from its farthest point).
    pub fn px_at_least(&self, eye: DVec3, focal_px: f64) -> f64 {
        if self.error <= 0.0 {
            return 0.0;
        }
        self.error as f64 * focal_px / ((DVec3::from(self.center.map(f64::from)) - eye).length() + self.radius as f64)
    }
}

/// The LOD parameters a cut is made for: the eye (scene-local), pixels per unit at unit
/// distance, and tau.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodView {
    pub eye: DVec3,
    pub focal_px: f64,
    pub tau: f64,
}

impl LodView {
    /// Whether the cut draws a cluster with bounds `c`: its own group's coarser version is too
    /// coarse and the group it came from is fine enough (the cut of zeux's clusterlod; Yoon 2003
    /// refines a front of vertices instead).
    pub fn takes(&self, c: &Cut) -> bool {
        c.lo.px(self.eye, self.focal_px) <= self.tau && c.hi.px(self.eye, self.focal_px) > self.tau
    }

    /// Whether the cut may take some cluster of the cut node `n` (never false when it does).
    pub fn may_take(&self, n: &NodeRecord) -> bool {
        let lo = ErrorBound { error: n.cut_lo_error, ..n.cut_hi };
        lo.px_at_least(self.eye, self.focal_px) <= self.tau && n.cut_hi.px(self.eye, self.focal_px) > self.tau
    }
}

/// What a traversal does at a BVH node it reached: draw a LOD node of it, refine into its
/// children, or both (a cluster hierarchy's coarse groups at a node and finer ones below it
/// cover different parts of a surface).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Selection {
    pub draw: Option<NodeId>,
    pub refine: bool,
}

/// The coarsest static LOD or HLOD of BVH node `node` whose projected error is at most `tau`
/// pixels (occlusion switch sec. 4.1), or `None` when none is fine enough.
pub fn select_lod(nodes: &[NodeRecord], node: NodeId, eye: DVec3, focal_px: f64, tau: f64) -> Option<NodeId> {
    let n = &nodes[node as usize];
    let b = n.aabb();
    n.lods().rev().find(|&l| !nodes[l as usize].is_cut() && projected_error_px(nodes[l as usize].error, &b, eye, focal_px) <= tau)
}

/// What to do at BVH node `node`: a static LOD or HLOD that meets tau stands for the whole
/// subtree; else the node's cut node when the cut may take some of its clusters, and its
/// children unless everything below is coarse enough already.
pub fn select(nodes: &[NodeRecord], node: NodeId, v: &LodView) -> Selection {
    if let Some(l) = select_lod(nodes, node, v.eye, v.focal_px, v.tau) {
        return Selection { draw: Some(l), refine: false };
    }
    let n = &nodes[node as usize];
    let draw = n.lods().find(|&l| nodes[l as usize].is_cut() && v.may_take(&nodes[l as usize]));
    let refine = n.kind() == NodeKind::Group && (!n.is_bounded() || n.cut_hi.px(v.eye, v.focal_px) > v.tau);
    Selection { draw, refine }
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

        /// A group's projection: at least the nearest point's (conservative), at least the
        /// farthest point's lower bound, and no smaller for a sphere that encloses it with an
        /// error at least as large (what keeps every chain of a cut monotone), from any eye.
        #[test]
        fn an_enclosing_sphere_projects_to_at_least_as_many_pixels(
            c in prop::array::uniform3(-100.0f32..100.0), r in 0.0f32..50.0,
            dir in prop::array::uniform3(-1.0f32..1.0), shift in 0.0f32..50.0, grow in 0.0f32..50.0,
            e in 0.0f32..10.0, more in 0.0f32..10.0, eye in prop::array::uniform3(-400.0f64..400.0),
        ) {
            let inner = ErrorBound { center: c, radius: r, error: e };
            let offset = Vec3::from(dir).normalize_or_zero() * shift;
            let outer = ErrorBound {
                center: (Vec3::from(c) + offset).into(),
                radius: (offset.length() + r + grow) * (1.0 + 1e-5) + 1e-3,
                error: e + more,
            };
            let eye = DVec3::from(eye);
            let nearest = inner.error as f64 * 1000.0 / ((DVec3::from(c.map(f64::from)) - eye).length() - r as f64);
            let px = inner.px(eye, 1000.0);
            prop_assert!(!px.is_nan() && px >= 0.0);
            prop_assert!(e == 0.0 || nearest <= 0.0 || px >= nearest * (1.0 - 1e-12), "{px} below the nearest point's {nearest}");
            prop_assert!(inner.px_at_least(eye, 1000.0) <= px * (1.0 + 1e-12));
            prop_assert!(outer.px(eye, 1000.0) >= px * (1.0 - 1e-9), "the enclosing sphere {} < {px}", outer.px(eye, 1000.0));
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
