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
#[derive(Clone, Debug)]
pub struct Frustum {
    planes: [(DVec3, f64); 5],
    eye: DVec3,
    forward: DVec3,
    near: f64,
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
        // Inward normals of the side planes through the eye.
        let side = |n: DVec3| (n.normalize(), -n.normalize().dot(eye));
        let planes = [
            side(f * tx + r), // left: n = r + f*tx  (points right/forward)
            side(f * tx - r), // right
            side(f * ty + u), // bottom
            side(f * ty - u), // top
            (f, -f.dot(eye + f * near)),
        ];
        Frustum { planes, eye, forward: f, near, max_extent_per_depth: GUARD_BAND_PX / focal_px }
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

    /// True when the box contains the eye, reaches in front of the near plane, or is so large
    /// for its depth that its faces reach beyond the rasteriser's guard band: such a box
    /// cannot be tested by rasterising it (paper 004 sec. 4: clamp or accept) and counts as
    /// visible.
    pub fn needs_no_test(&self, b: &Aabb) -> bool {
        let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
        let q = DVec3::select(self.forward.cmpge(DVec3::ZERO), lo, hi);
        // Nearest box corner along the view direction closer than the near plane (with a
        // margin for rounding), or the eye in the box.
        let depth = self.forward.dot(q - self.eye);
        depth <= self.near * 1.01
            || (self.eye.cmpge(lo).all() && self.eye.cmple(hi).all())
            || (hi - lo).max_element() > depth * self.max_extent_per_depth
    }
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
