//! A camera turned into what culling and drawing need, in the scene's local coordinates.
//!
//! Precision (Yoon 2003 sec. 5.4, conservative up to screen precision): the eye is kept in f64 relative to the scene origin;
//! everything sent to the GPU is camera-relative f32, so a scene 1e7 units from the world
//! origin renders like one at the origin.

use crate::frustum::{Frustum, grow_for_test};
use glam::{DMat4, DQuat, DVec3, Mat4, Vec3};
use osw_scene::error_metric::LodView;
use osw_scene::{Aabb, Camera, NodeRecord};

/// What a traversal cuts the hierarchy by: its nodes, the view, and tau (pixels of error).
#[derive(Clone, Copy)]
pub struct Cut<'a> {
    pub nodes: &'a [NodeRecord],
    pub view: &'a View,
    pub tau: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct View {
    /// Eye in scene-local coordinates (world - scene origin), f64.
    pub eye: DVec3,
    pub orientation: DQuat,
    pub fovy_rad: f64,
    pub width: u32,
    pub height: u32,
    /// Near plane distance (world units); the far plane is at infinity (reversed Z).
    pub near: f64,
    /// Pixels per unit of size/distance: converts object-space error to pixels.
    pub focal_px: f64,
    pub frustum: Frustum,
    /// What a cluster hierarchy's cut is made for when drawing: this camera's eye at tau 0
    /// unless [`View::at_tau`] says otherwise (popping draws one camera's cut from another).
    pub lod: LodView,
}

impl View {
    /// `camera` must be validated (finite, unit orientation, fovy in (0, 180)); `width` and
    /// `height` >= 1; `near` > 0.
    pub fn new(camera: &Camera, scene_origin: DVec3, width: u32, height: u32, near: f64) -> View {
        let eye = camera.position - scene_origin;
        let fovy_rad = camera.fovy_deg.to_radians();
        let aspect = width as f64 / height as f64;
        View {
            eye,
            orientation: camera.orientation,
            fovy_rad,
            width,
            height,
            near,
            focal_px: camera.focal_px(height),
            frustum: Frustum::new(eye, camera.orientation, fovy_rad, aspect, near, camera.focal_px(height)),
            lod: LodView { eye, focal_px: camera.focal_px(height), tau: 0.0 },
        }
    }

    /// The same view drawing the cut at `tau`.
    pub fn at_tau(self, tau: f64) -> View {
        View { lod: LodView { tau, ..self.lod }, ..self }
    }

    /// The LOD parameters of this camera at `tau`: what traversals select with.
    pub fn lod_at(&self, tau: f64) -> LodView {
        // A negative control's fault (crate::fault): LODs too coarse for tau.
        let tau = if crate::fault::on("lod-cut") { tau * 4.0 } else { tau };
        LodView { eye: self.eye, focal_px: self.focal_px, tau }
    }

    /// Camera-relative view-projection: rotation-only view times a reversed-Z projection with
    /// an infinite far plane (depth 1 at the near plane, 0 at infinity).
    pub fn view_proj(&self) -> Mat4 {
        let view = DMat4::from_quat(self.orientation.inverse());
        let f = 1.0 / (self.fovy_rad * 0.5).tan();
        let aspect = self.width as f64 / self.height as f64;
        // Right-handed view space (looking down -z) to wgpu clip space: depth = near / -z.
        let proj = DMat4::from_cols(
            glam::DVec4::new(f / aspect, 0.0, 0.0, 0.0),
            glam::DVec4::new(0.0, f, 0.0, 0.0),
            glam::DVec4::new(0.0, 0.0, 0.0, -1.0),
            glam::DVec4::new(0.0, 0.0, self.near, 0.0),
        );
        (proj * view).as_mat4()
    }

    /// The same view with a frustum that keeps everything: for references that must not share
    /// the frustum test they judge.
    pub fn without_frustum(&self) -> View {
        View { frustum: Frustum::everything(), ..self.clone() }
    }

    /// What to add to a scene-local position to make it camera-relative.
    pub fn offset(&self) -> Vec3 {
        (-self.eye).as_vec3()
    }

    /// A scene-local point made camera-relative in f64, then f32.
    pub fn relative(&self, p: Vec3) -> Vec3 {
        (p.as_dvec3() - self.eye).as_vec3()
    }

    /// Box `b` made camera-relative and grown for an occlusion test (GPU or CPU): see
    /// [`grow_for_test`].
    pub fn test_box(&self, b: &Aabb) -> (DVec3, DVec3) {
        grow_for_test(b.min.as_dvec3() - self.eye, b.max.as_dvec3() - self.eye, self.eye, self.focal_px)
    }
}

/// Near plane for a scene of diagonal `diag`: small enough that walking cameras never clip
/// nearby geometry, large enough to keep depth precision (reversed Z keeps it nearly uniform).
pub fn near_for(diag: f64) -> f64 {
    (diag * 1e-5).clamp(1e-6, 0.05)
}

/// The near plane every renderer uses for `scene`: [`near_for`] its root box's diagonal.
pub fn near_of(scene: &osw_scene::SceneFile) -> f64 {
    near_for(scene.node(0).aabb().extent().length() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frustum::{DEPTH_MARGIN, SNAP_PX};
    use crate::hzb::Footprint;
    use glam::{DQuat, Vec3};

    /// Where `b` lands through `view` as it is tested (grown), and as it is:
    /// (x0, y0, x1, y1, nearest reversed-Z depth) each.
    fn footprints(view: &View, b: &Aabb) -> [(f64, f64, f64, f64, f64); 2] {
        let vp = view.view_proj().as_dmat4();
        let Footprint::Rect { x0, y0, x1, y1, nearest } = Footprint::of_box(&vp, view, b) else { panic!("box behind the eye") };
        let mut raw = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY, 0.0f64);
        for c in 0..8 {
            let p = DVec3::select(glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0), b.max.as_dvec3(), b.min.as_dvec3()) - view.eye;
            let q = vp * p.extend(1.0);
            let (x, y) = ((q.x / q.w + 1.0) * 0.5 * view.width as f64, (1.0 - q.y / q.w) * 0.5 * view.height as f64);
            raw = (raw.0.min(x), raw.1.min(y), raw.2.max(x), raw.3.max(y), raw.4.max(q.z / q.w));
        }
        [(x0, y0, x1, y1, nearest), raw]
    }

    #[test]
    fn the_openarena_floor_reaches_nearer_than_its_own_fragment() {
        // OpenArena's 68 maps, walk frame 59, 512x512: leaf 2850 (a floor 2.6 km off) drew
        // pixel (339, 242) at depth 1.9080608e-5 (read back), nearer than its vertices, and its
        // box as tested before reached only 1.9080248e-5 there: hidden behind itself.
        let camera = Camera {
            position: DVec3::new(1424.5834350585938, -79.783203125, 1188.7167358398438),
            orientation: DQuat::from_xyzw(0.0, std::f64::consts::FRAC_1_SQRT_2, 0.0, -std::f64::consts::FRAC_1_SQRT_2),
            fovy_deg: 60.0,
        };
        let view = View::new(&camera, DVec3::new(2379.0, 30.0, 2004.0), 512, 512, 0.05);
        let floor = Aabb { min: Vec3::new(1666.0974, -33.2512, -322.0577), max: Vec3::new(1679.1023, -30.0, -213.1425) };
        let [(x0, y0, x1, y1, nearest), raw] = footprints(&view, &floor);
        assert!(nearest >= 1.9080608e-5, "{nearest}");
        assert!(x0 < 339.5 && 339.5 < x1 && y0 < 242.5 && 242.5 < y1, "{x0} {y0} {x1} {y1}");
        // The box as it is does not.
        assert!(raw.4 < 1.9080608e-5, "{raw:?}");
    }

    proptest::proptest! {
        /// Any box in front of the eye is tested at least SNAP_PX pixels wider on each side and
        /// DEPTH_MARGIN nearer (in reversed-Z depth) than it projects.
        #[test]
        fn a_tested_box_is_wider_by_the_snap_and_nearer_by_the_margin(
            c in proptest::array::uniform3(-1e4f32..1e4),
            e in proptest::array::uniform3(0.0f32..50.0),
            eye in proptest::array::uniform3(-1e4f64..1e4),
            dir in proptest::array::uniform3(-1.0f64..1.0),
            fovy in 1.0f64..170.0,
        ) {
            let b = Aabb { min: Vec3::from(c), max: Vec3::from(c) + Vec3::from(e) };
            let camera = Camera::look_along(DVec3::from(eye), DVec3::from(dir).try_normalize().unwrap_or(DVec3::X), fovy);
            let view = View::new(&camera, DVec3::ZERO, 640, 480, 0.05);
            proptest::prop_assume!(!view.frustum.needs_no_test(&b));
            let [(a0, b0, a1, b1, n), (x0, y0, x1, y1, nearest)] = footprints(&view, &b);
            proptest::prop_assert!(a0 <= x0 - SNAP_PX && b0 <= y0 - SNAP_PX && a1 >= x1 + SNAP_PX && b1 >= y1 + SNAP_PX);
            proptest::prop_assert!(n >= nearest * (1.0 + DEPTH_MARGIN) * (1.0 - 1e-9), "{n} vs {nearest}");
        }
    }
}
