//! View-frustum tests of boxes in scene-local f64 coordinates: four side planes and the near
//! plane (the far plane is at infinity).

use glam::{DQuat, DVec3};
use osw_scene::Aabb;

/// How far outside the viewport, in pixels, a box's rasterised faces may reach and still be
/// tested reliably. Rasterisers clip against a guard band of limited fixed-point range; faces
/// beyond it were seen dropped (lavapipe: a box 1e11 wide, 0.9 in front of the eye, tested
/// occluded on an empty depth buffer). A box that large on screen covers the view anyway.
pub const GUARD_BAND_PX: f64 = 8192.0;

/// Planes as (normal, d): a point p is inside when normal.dot(p) + d >= 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Frustum {
    planes: [(DVec3, f64); 5],
    eye: DVec3,
    forward: DVec3,
    near: f64,
    /// Pixels per unit at unit distance.
    focal_px: f64,
    /// Largest box extent per unit of depth that projects inside the guard band.
    max_extent_per_depth: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Containment {
    Outside,
    Intersects,
    Inside,
}

impl Frustum {
    /// `focal_px`: pixels per unit of size at unit distance.
    pub fn new(eye: DVec3, orientation: DQuat, fovy: f64, aspect: f64, near: f64, focal_px: f64) -> Frustum {
        let (r, u, f) = (orientation * DVec3::X, orientation * DVec3::Y, orientation * DVec3::NEG_Z);
        let ty = (fovy * 0.5).tan();
        let tx = ty * aspect;
        // A negative control's fault (crate::fault): culling drops visible geometry at the
        // left edge, and the render checks must fail against the independent exact reference.
        let tl = if crate::fault::on("frustum") { tx * 0.5 } else { tx };
        // Inward normals of the side planes through the eye.
        let side = |n: DVec3| (n.normalize(), -n.normalize().dot(eye));
        let planes = [
            side(f * tl + r), // left: n = r + f*tx  (points right/forward)
            side(f * tx - r), // right
            side(f * ty + u), // bottom
            side(f * ty - u), // top
            (f, -f.dot(eye + f * near)),
        ];
        Frustum { planes, eye, forward: f, near, focal_px, max_extent_per_depth: GUARD_BAND_PX / focal_px }
    }

    /// A frustum that contains every box: no plane rejects anything, no box needs to be
    /// accepted untested.
    pub fn everything() -> Frustum {
        Frustum {
            planes: [(DVec3::ZERO, 0.0); 5],
            eye: DVec3::ZERO,
            forward: DVec3::ZERO,
            near: f64::NEG_INFINITY,
            focal_px: f64::INFINITY,
            max_extent_per_depth: f64::INFINITY,
        }
    }

    pub fn classify(&self, b: &Aabb) -> Containment {
        let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
        let mut inside = true;
        for (n, d) in &self.planes {
            // The box corner farthest along n (p-vertex) and nearest (n-vertex).
            let p = DVec3::select(n.cmpge(DVec3::ZERO), hi, lo);
            let q = DVec3::select(n.cmpge(DVec3::ZERO), lo, hi);
            if n.dot(p) + d < 0.0 {
                return Containment::Outside;
            }
            if n.dot(q) + d < 0.0 {
                inside = false;
            }
        }
        if inside { Containment::Inside } else { Containment::Intersects }
    }

    /// True when a sphere lies wholly outside one of the planes.
    pub fn sphere_outside(&self, center: DVec3, radius: f64) -> bool {
        self.planes.iter().any(|(n, d)| n.dot(center) + d < -radius)
    }

    /// True when the box as it would be tested ([`grow_for_test`]) contains the
    /// eye, reaches in front of the near plane, or is so large for its depth that its faces
    /// reach beyond the rasteriser's guard band: such a box cannot be tested by rasterising it
    /// (Yoon 2003 sec. 5.3.2: clamp or accept) and counts as visible.
    pub fn needs_no_test(&self, b: &Aabb) -> bool {
        let (lo, hi) = grow_for_test(b.min.as_dvec3() - self.eye, b.max.as_dvec3() - self.eye, self.eye, self.focal_px);
        let q = DVec3::select(self.forward.cmpge(DVec3::ZERO), lo, hi);
        // Nearest box corner along the view direction closer than the near plane (with a
        // margin for rounding), or the eye in the box.
        let depth = self.forward.dot(q);
        depth <= self.near * 1.01
            || (lo.cmple(DVec3::ZERO).all() && hi.cmpge(DVec3::ZERO).all())
            || (hi - lo).max_element() > depth * self.max_extent_per_depth
    }
}

/// Pixels by which a tested box outgrows its silhouette ([`grow_for_test`]): 16 times the
/// half step of an 8-bit sub-pixel grid, the coarsest Vulkan and D3D allow.
pub const SNAP_PX: f64 = 1.0 / 32.0;

/// Share of its distance by which a tested box reaches towards the eye ([`grow_for_test`]):
/// 1/1024, 50 times the error measured on OpenArena.
pub const DEPTH_MARGIN: f64 = 1.0 / 1024.0;

/// A camera-relative box `lo..hi` as every occlusion test tests it (the GPU's exact and
/// pyramid tests, the CPU pyramid, ovc), and as [`Frustum::needs_no_test`]
/// judges whether it can be tested at all. `eye`: the scene-local eye; `focal_px`: pixels per
/// unit at unit distance. Conservative against three roundings:
/// - f32: the corners go to the GPU as f32, and the geometry drawn into the depth buffer is
///   made camera-relative in f32 with the eye rounded to f32 (draw.wgsl), up to two ulps of
///   the eye's coordinates nearer than in f64. A relative epsilon, which also gives a flat box
///   an area.
/// - Vertex snapping: a rasteriser snaps every vertex to its sub-pixel grid (1/256 px on
///   lavapipe), the box's and the geometry's independently, so a pixel centre within a snap of
///   the box's silhouette, where its geometry touches it, can be covered by the geometry and
///   missed by the box. Grown by [`SNAP_PX`] at the box's farthest point.
/// - Depth extrapolated outside a triangle: a pixel centre just outside a thin triangle that
///   snapping covers gets a depth from the triangle's plane, beyond its vertices' depths. On
///   OpenArena a floor 2.6 km off, 0.55 px tall and seen 1.7 degrees off edge-on, covered one
///   pixel 0.00025 px outside its triangles at a depth 2e-5 (relative) nearer than every vertex
///   and than its own box: HC found the box hidden behind its own floor, which showed in
///   frustum culling's frame. The box test's depth bias (64 steps, 1e-10 at that depth; no
///   slope on a face seen head-on) is absolute; the box is reached towards the eye by
///   [`DEPTH_MARGIN`] of its distance, which scales its depth by as much and leaves its
///   silhouette as it is (a perspective projection does not change under scaling about the
///   eye).
pub fn grow_for_test(lo: DVec3, hi: DVec3, eye: DVec3, focal_px: f64) -> (DVec3, DVec3) {
    let far = lo.abs().max(hi.abs());
    let eps = (hi - lo).max_element() * 1e-6 + far.max_element() * 1e-6 + eye.abs().max_element() * 2.4e-7;
    let snap = far.length() / focal_px * SNAP_PX;
    let (lo, hi) = (lo - (eps + snap), hi + (eps + snap));
    let s = 1.0 / (1.0 + DEPTH_MARGIN);
    (lo.min(lo * s), hi.max(hi * s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn looking_down_neg_z() -> Frustum {
        // 512 pixels high: 256 pixels per unit at unit distance.
        Frustum::new(DVec3::ZERO, DQuat::IDENTITY, 90f64.to_radians(), 1.0, 0.1, 256.0)
    }

    fn cube(c: Vec3, r: f32) -> Aabb {
        Aabb::new(c - Vec3::splat(r), c + Vec3::splat(r))
    }

    #[test]
    fn boxes_in_front_behind_and_beside() {
        let f = looking_down_neg_z();
        assert_eq!(f.classify(&cube(Vec3::new(0.0, 0.0, -10.0), 1.0)), Containment::Inside);
        assert_eq!(f.classify(&cube(Vec3::new(0.0, 0.0, 10.0), 1.0)), Containment::Outside);
        // 90 degrees: the side planes are at 45 degrees; x = 20 at z = -10 is outside.
        assert_eq!(f.classify(&cube(Vec3::new(20.0, 0.0, -10.0), 1.0)), Containment::Outside);
        assert_eq!(f.classify(&cube(Vec3::new(10.0, 0.0, -10.0), 1.0)), Containment::Intersects);
        // Infinitely far is still inside: no far plane.
        assert_eq!(f.classify(&cube(Vec3::new(0.0, 0.0, -1e9), 1.0)), Containment::Inside);
    }

    /// The frustum built another way: its four edge rays through the image corners, each side
    /// plane through the eye and two adjacent rays, and the near plane; a box is outside when
    /// all eight corners are outside one plane, inside when all are inside every plane.
    fn brute_force(eye: DVec3, q: DQuat, fovy: f64, aspect: f64, near: f64, b: &Aabb) -> (Containment, f64) {
        let (ty, f) = ((fovy * 0.5).tan(), q * DVec3::NEG_Z);
        let ray = |sx: f64, sy: f64| q * DVec3::new(sx * ty * aspect, sy * ty, -1.0);
        let corners_px = [ray(-1.0, -1.0), ray(1.0, -1.0), ray(1.0, 1.0), ray(-1.0, 1.0)];
        // The plane through the eye and adjacent corner rays a, b (counter-clockwise in the
        // image): b × a is its inward normal; a point's signed distance.
        let mut planes: Vec<Box<dyn Fn(DVec3) -> f64>> = (0..4)
            .map(|k| {
                let n = corners_px[(k + 1) % 4].cross(corners_px[k]).normalize();
                Box::new(move |p: DVec3| n.dot(p - eye)) as Box<dyn Fn(DVec3) -> f64>
            })
            .collect();
        planes.push(Box::new(move |p: DVec3| f.dot(p - eye) - near));
        let corners: Vec<DVec3> = (0..8)
            .map(|i| {
                let pick = |bit: usize, lo: f32, hi: f32| if i & bit == 0 { lo as f64 } else { hi as f64 };
                DVec3::new(pick(1, b.min.x, b.max.x), pick(2, b.min.y, b.max.y), pick(4, b.min.z, b.max.z))
            })
            .collect();
        let d: Vec<Vec<f64>> = planes.iter().map(|pl| corners.iter().map(|&c| pl(c)).collect()).collect();
        // How close a corner is to any plane, relative to the scene's scale: a tie band.
        let scale = corners.iter().map(|c| (*c - eye).length()).fold(near, f64::max);
        let tie = d.iter().flatten().map(|x| x.abs()).fold(f64::INFINITY, f64::min) / scale;
        let c = if d.iter().any(|row| row.iter().all(|&x| x < 0.0)) {
            Containment::Outside
        } else if d.iter().all(|row| row.iter().all(|&x| x >= 0.0)) {
            Containment::Inside
        } else {
            Containment::Intersects
        };
        (c, tie)
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]
        #[test]
        fn classify_agrees_with_the_brute_force_frustum(
            eye in proptest::array::uniform3(-50.0f64..50.0),
            axis in proptest::array::uniform3(-1.0f64..1.0),
            angle in 0.0f64..std::f64::consts::TAU,
            fovy_deg in 1.0f64..170.0,
            aspect_log2 in -4.0f64..4.0,
            near in 1e-4f64..0.5,
            centre in proptest::array::uniform3(-60.0f32..60.0),
            half in proptest::array::uniform3(0.0f32..20.0),
        ) {
            let axis = DVec3::from_array(axis);
            let q = if axis.length() < 1e-3 { DQuat::IDENTITY } else { DQuat::from_axis_angle(axis.normalize(), angle) };
            let (eye, aspect, fovy) = (DVec3::from_array(eye), 2f64.powf(aspect_log2), fovy_deg.to_radians());
            let b = Aabb::new(Vec3::from_array(centre) - Vec3::from_array(half), Vec3::from_array(centre) + Vec3::from_array(half));
            let f = Frustum::new(eye, q, fovy, aspect, near, 256.0);
            let (want, tie) = brute_force(eye, q, fovy, aspect, near, &b);
            let got = f.classify(&b);
            // Within rounding of a plane the two constructions may differ; elsewhere never.
            proptest::prop_assert!(got == want || tie < 1e-9, "classify {got:?}, brute force {want:?} (tie {tie:e}): {b:?}");
            // Conservative: a box with a corner strictly inside every plane is never outside.
            if want != Containment::Outside {
                proptest::prop_assert!(got != Containment::Outside || tie < 1e-9);
            }
        }

        #[test]
        fn boxes_across_the_near_plane_are_kept_and_not_tested(
            fovy_deg in 1.0f64..170.0,
            aspect_log2 in -4.0f64..4.0,
            near in 1e-4f64..0.5,
            across in 0.05f64..0.95,
            half in 1e-3f32..1.0,
        ) {
            // A box on the view axis whose front face lies `across` of the near distance from
            // the eye and whose back reaches past the near plane.
            let f = Frustum::new(DVec3::ZERO, DQuat::IDENTITY, fovy_deg.to_radians(), 2f64.powf(aspect_log2), near, 256.0);
            let front = -(near * across) as f32;
            let b = Aabb::new(Vec3::new(-half, -half, front - 2.0 * near as f32 - half), Vec3::new(half, half, front));
            proptest::prop_assert_ne!(f.classify(&b), Containment::Outside);
            proptest::prop_assert!(f.needs_no_test(&b));
        }
    }

    #[test]
    fn near_plane_boxes_need_no_test() {
        let f = looking_down_neg_z();
        assert!(f.needs_no_test(&cube(Vec3::ZERO, 1.0)), "contains the eye");
        assert!(f.needs_no_test(&cube(Vec3::new(0.0, 0.0, -1.0), 0.95)), "crosses the near plane");
        assert!(!f.needs_no_test(&cube(Vec3::new(0.0, 0.0, -10.0), 1.0)));
        // 8192 / 256: a box wider than 32 times its depth is not rasterised.
        let slab = |half: f32| Aabb::new(Vec3::new(-half, -half, -31.0), Vec3::new(half, half, -1.0));
        assert!(f.needs_no_test(&slab(17.0)), "34 units wide at depth 1: beyond the guard band");
        assert!(!f.needs_no_test(&slab(15.0)), "30 units wide at depth 1: tested");
    }
}
