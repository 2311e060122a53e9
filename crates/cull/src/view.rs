//! A camera turned into what culling and drawing need, in the scene's local coordinates.
//!
//! Precision (issue 3, paper 004 sec. 5): the eye is kept in f64 relative to the scene origin;
//! everything sent to the GPU is camera-relative f32, so a scene 1e7 units from the world
//! origin renders like one at the origin.

use crate::frustum::Frustum;
use glam::{DMat4, DQuat, DVec3, Mat4, Vec3};
use osw_scene::{Aabb, Camera};

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
        }
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

    /// Box `b` made camera-relative for an occlusion test (GPU or CPU), grown by a relative
    /// epsilon so that f32 rounding of its corners never shrinks it (conservative) and a flat
    /// box keeps an area. The geometry drawn into the depth buffer is made camera-relative in
    /// f32 with the eye rounded to f32 (draw.wgsl): it may sit up to two ulps of the eye's
    /// coordinates nearer than in f64, and a box must not hide behind its own contents.
    pub fn test_box(&self, b: &Aabb) -> (DVec3, DVec3) {
        let (lo, hi) = (b.min.as_dvec3() - self.eye, b.max.as_dvec3() - self.eye);
        let eps = (hi - lo).max_element() * 1e-6 + lo.abs().max(hi.abs()).max_element() * 1e-6 + self.eye.abs().max_element() * 2.4e-7;
        (lo - eps, hi + eps)
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
