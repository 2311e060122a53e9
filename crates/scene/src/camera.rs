//! Cameras: f64 world position (scenes far from the origin keep their precision), orientation,
//! vertical field of view. Convention: the camera looks down its local -Z with +Y up (as glam
//! and OpenGL); `orientation` turns local axes into world axes.

pub use glam::{DQuat, DVec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: DVec3,
    /// Unit quaternion.
    pub orientation: DQuat,
    /// Vertical field of view, degrees, in (0, 180).
    pub fovy_deg: f64,
}

impl Camera {
    /// A camera at `eye` looking at `target` with +Y up (any up when looking straight up/down).
    pub fn look_at(eye: DVec3, target: DVec3, fovy_deg: f64) -> Camera {
        Camera::look_along(eye, target - eye, fovy_deg)
    }

    /// A camera at `eye` looking along `dir` (need not be unit) with +Y up. Prefer this to
    /// [`Camera::look_at`] far from the origin: `target - eye` loses the direction's low bits.
    pub fn look_along(eye: DVec3, dir: DVec3, fovy_deg: f64) -> Camera {
        let f = dir.normalize_or(DVec3::NEG_Z);
        let up = if f.cross(DVec3::Y).length_squared() < 1e-12 { DVec3::Z } else { DVec3::Y };
        let r = f.cross(up).normalize();
        let u = r.cross(f);
        let orientation = DQuat::from_mat3(&glam::DMat3::from_cols(r, u, -f)).normalize();
        Camera { position: eye, orientation, fovy_deg }
    }

    pub fn forward(&self) -> DVec3 {
        self.orientation * DVec3::NEG_Z
    }

    /// Focal length in pixels for an image `height_px` tall: pixels per unit of
    /// (size / distance).
    pub fn focal_px(&self, height_px: u32) -> f64 {
        height_px as f64 * 0.5 / (self.fovy_deg.to_radians() * 0.5).tan()
    }

    /// Checks that every number is usable: finite position, non-degenerate orientation,
    /// fovy in (0, 180). Returns the camera with its orientation normalised.
    pub fn validated(self) -> Result<Camera, CameraError> {
        if !self.position.is_finite() {
            return Err(CameraError::Position(self.position));
        }
        let q = self.orientation;
        // A finite quaternion can still have a length that overflows (components near 1e200,
        // found by fuzzing): normalising it would give zeros.
        if !(q.is_finite() && q.length() >= 1e-6 && q.length().is_finite()) {
            return Err(CameraError::Orientation(q));
        }
        if !(self.fovy_deg > 0.0 && self.fovy_deg < 180.0) {
            return Err(CameraError::Fovy(self.fovy_deg));
        }
        Ok(Camera { orientation: q.normalize(), ..self })
    }
}

/// A number of a camera that cannot be used ([`Camera::validated`]).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum CameraError {
    #[error("non-finite camera position {0:?}")]
    Position(DVec3),
    #[error("bad camera orientation {0:?}: expected a non-zero quaternion of finite length")]
    Orientation(DQuat),
    #[error("bad fovy {0} degrees: expected in (0, 180)")]
    Fovy(f64),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_points_forward() {
        let c = Camera::look_at(DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0, 2.0, -7.0), 60.0);
        assert!((c.forward() - DVec3::NEG_Z).length() < 1e-12);
        let c = Camera::look_at(DVec3::ZERO, DVec3::new(0.0, -5.0, 0.0), 60.0);
        assert!((c.forward() - DVec3::NEG_Y).length() < 1e-12);
        assert!((c.focal_px(1000) - 500.0 / 30f64.to_radians().tan()).abs() < 1e-9);
    }

    #[test]
    fn validation_rejects_unusable_numbers() {
        let ok = Camera::look_at(DVec3::ZERO, DVec3::X, 60.0);
        assert!(ok.validated().is_ok());
        assert!(Camera { position: DVec3::new(f64::NAN, 0.0, 0.0), ..ok }.validated().is_err());
        assert!(Camera { orientation: DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0), ..ok }.validated().is_err());
        // Finite, but its length overflows (found by fuzzing the path CSV).
        assert!(Camera { orientation: DQuat::from_xyzw(2e200, 0.2, 0.3, 0.9), ..ok }.validated().is_err());
        assert!(Camera { fovy_deg: 180.0, ..ok }.validated().is_err());
        assert!(Camera { fovy_deg: f64::INFINITY, ..ok }.validated().is_err());
    }
}
