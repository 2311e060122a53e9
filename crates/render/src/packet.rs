//! The camera as the wire carries it (`osw_wire::CameraPacket`) and as the renderer uses it
//! (`osw_scene::Camera`): the display sends one, the nodes render from it.

use osw_scene::Camera;
use osw_wire::CameraPacket;

/// Frame `frame`'s packet for `camera` at `tau_px`, sampled at `sampled_us`.
pub fn packet(frame: u64, camera: &Camera, tau_px: f64, sampled_us: u64) -> CameraPacket {
    CameraPacket {
        frame,
        position: camera.position.to_array(),
        orientation: camera.orientation.to_array(),
        fovy_deg: camera.fovy_deg,
        tau_px,
        sampled_us,
    }
}

/// The camera a packet carries (its rotation normalised: the wire carries f64 components).
pub fn camera(p: &CameraPacket) -> Camera {
    Camera { position: p.position.into(), orientation: glam::DQuat::from_array(p.orientation).normalize(), fovy_deg: p.fovy_deg }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_camera_survives_its_packet() {
        let c = Camera::look_at(DVec3::new(1e7, 2.5, -3.0), DVec3::new(0.0, 1.0, 40.0), 55.0);
        let p = packet(7, &c, 1.5, 99);
        assert_eq!((p.frame, p.tau_px, p.sampled_us), (7, 1.5, 99));
        let back = camera(&p);
        assert_eq!(back.position, c.position);
        assert!(back.orientation.abs_diff_eq(c.orientation, 1e-15));
        assert_eq!(back.fovy_deg, c.fovy_deg);
    }
}
