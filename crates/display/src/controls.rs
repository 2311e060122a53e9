//! Walkthrough controls: held keys move and turn the camera, a mouse drag looks around, single
//! presses change speed and tau or ask for an action. Independent of the window library, so
//! that it is tested without a window.
//!
//! Fly mode: W/S move along the view direction, A/D sideways, Q/E down and up along world Y.
//! Yaw turns about world Y, pitch about the camera's X, kept within ±89° so that the view
//! never flips over the pole.

use osw_scene::Camera;
use osw_scene::camera::{DQuat, DVec3};

/// A key as the controls see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    Forward,
    Back,
    Left,
    Right,
    Down,
    Up,
    TurnLeft,
    TurnRight,
    TurnUp,
    TurnDown,
    Faster,
    Slower,
    TauUp,
    TauDown,
    Do(Action),
}

/// What a single key press asks of the display.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Colour nodes by state (visible / frustum-culled / occlusion-culled), or by object.
    Colours,
    /// Freeze the culling camera (the cluster keeps culling for it) while the viewer moves on.
    Freeze,
    /// Start or stop recording the camera path.
    Record,
    Screenshot,
    /// Show or hide the statistics overlay.
    Overlay,
    Quit,
}

/// The held keys, in the order of [`Key`]'s movement variants.
const HELD: usize = 10;

/// Tau steps of the `[` and `]` keys, pixels.
pub const TAU_STEPS: [f64; 10] = [0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0, 50.0];

/// Turn rate of the arrow keys, radians a second; mouse look, radians a pixel.
const TURN_RATE: f64 = std::f64::consts::FRAC_PI_2;
const LOOK_PER_PX: f64 = 0.004;
const MAX_PITCH: f64 = 89.0 * std::f64::consts::PI / 180.0;

pub struct Controls {
    pub position: DVec3,
    /// Radians about world Y; 0 looks down -Z.
    yaw: f64,
    /// Radians; positive looks up.
    pitch: f64,
    pub fovy_deg: f64,
    /// World units a second.
    pub speed: f64,
    pub tau: f64,
    held: [bool; HELD],
}

impl Controls {
    pub fn new(start: &Camera, speed: f64, tau: f64) -> Controls {
        let f = start.forward();
        Controls {
            position: start.position,
            yaw: (-f.x).atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            fovy_deg: start.fovy_deg,
            speed,
            tau,
            held: [false; HELD],
        }
    }

    pub fn camera(&self) -> Camera {
        // Normalised here, as a path's cameras are when read: live and replayed frames match.
        let orientation = (DQuat::from_rotation_y(self.yaw) * DQuat::from_rotation_x(self.pitch)).normalize();
        Camera { position: self.position, orientation, fovy_deg: self.fovy_deg }
    }

    /// A key went down (`down`) or up. Returns the action of a single press.
    pub fn key(&mut self, key: Key, down: bool) -> Option<Action> {
        let held = match key {
            Key::Forward => 0,
            Key::Back => 1,
            Key::Left => 2,
            Key::Right => 3,
            Key::Down => 4,
            Key::Up => 5,
            Key::TurnLeft => 6,
            Key::TurnRight => 7,
            Key::TurnUp => 8,
            Key::TurnDown => 9,
            _ if !down => return None,
            Key::Faster => return self.set_speed(self.speed * 2.0),
            Key::Slower => return self.set_speed(self.speed * 0.5),
            Key::TauUp => return self.set_tau(TAU_STEPS.iter().copied().find(|&t| t > self.tau)),
            Key::TauDown => return self.set_tau(TAU_STEPS.iter().rev().copied().find(|&t| t < self.tau)),
            Key::Do(a) => return Some(a),
        };
        self.held[held] = down;
        None
    }

    fn set_speed(&mut self, s: f64) -> Option<Action> {
        // Bounded both ways: a speed that underflows to 0 or overflows to infinity never
        // comes back by halving or doubling.
        self.speed = s.clamp(1e-6, 1e12);
        None
    }

    fn set_tau(&mut self, t: Option<f64>) -> Option<Action> {
        self.tau = t.unwrap_or(self.tau);
        None
    }

    /// A mouse drag of (dx, dy) pixels: right turns right, down looks down.
    pub fn drag(&mut self, dx: f64, dy: f64) {
        if dx.is_finite() && dy.is_finite() {
            self.turn(-dx * LOOK_PER_PX, -dy * LOOK_PER_PX);
        }
    }

    fn turn(&mut self, yaw: f64, pitch: f64) {
        self.yaw = (self.yaw + yaw).rem_euclid(std::f64::consts::TAU);
        self.pitch = (self.pitch + pitch).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves and turns by the held keys for `dt` seconds (at most a quarter second: a stall
    /// must not throw the camera across the scene).
    pub fn advance(&mut self, dt: f64) {
        let dt = if dt.is_finite() { dt.clamp(0.0, 0.25) } else { 0.0 };
        let held = self.held;
        let h = |k: usize| held[k] as i32 as f64;
        self.turn((h(6) - h(7)) * TURN_RATE * dt, (h(8) - h(9)) * TURN_RATE * dt);
        let cam = self.camera();
        let right = cam.orientation * DVec3::X;
        let step = cam.forward() * (h(0) - h(1)) + right * (h(3) - h(2)) + DVec3::Y * (h(5) - h(4));
        self.position += step * self.speed * dt;
    }

    /// Every key counts as released (the window lost the keyboard).
    pub fn release_all(&mut self) {
        self.held = [false; HELD];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start() -> Camera {
        Camera::look_along(DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0, -0.5, -2.0), 60.0)
    }

    #[test]
    fn starts_where_the_start_camera_looks() {
        let c = Controls::new(&start(), 1.0, 0.0).camera();
        assert!((c.forward() - start().forward()).length() < 1e-12, "{:?}", c.forward());
        assert_eq!(c.position, start().position);
    }

    #[test]
    fn held_keys_move_at_speed_and_stop_when_released() {
        let mut k = Controls::new(&start(), 2.0, 0.0);
        k.key(Key::Forward, true);
        k.advance(0.1);
        let moved = k.position - start().position;
        assert!((moved - start().forward() * 0.2).length() < 1e-12, "{moved:?}");
        k.key(Key::Forward, false);
        let p = k.position;
        k.advance(0.1);
        assert_eq!(k.position, p);
        k.key(Key::Up, true);
        k.advance(0.1);
        assert!((k.position - p - DVec3::Y * 0.2).length() < 1e-12);
    }

    #[test]
    fn pitch_stays_off_the_pole_and_nothing_turns_nan() {
        let mut k = Controls::new(&start(), 1.0, 0.0);
        k.drag(0.0, -1e9);
        let f = k.camera().forward();
        assert!(f.is_finite() && f.y < 1.0 && f.y > MAX_PITCH.sin() - 1e-9, "{f:?}");
        k.drag(f64::NAN, f64::INFINITY);
        k.key(Key::Forward, true);
        k.advance(f64::NAN);
        k.advance(1e300);
        assert!(k.camera().validated().is_ok() && k.position.is_finite());
        for _ in 0..2000 {
            k.key(Key::Faster, true);
        }
        k.advance(0.25);
        assert!(k.position.is_finite());
    }

    #[test]
    fn tau_steps_up_and_down_and_stops_at_the_ends() {
        let mut k = Controls::new(&start(), 1.0, 1.5);
        k.key(Key::TauUp, true);
        assert_eq!(k.tau, 2.0);
        k.key(Key::TauUp, false);
        assert_eq!(k.tau, 2.0, "key release does nothing");
        for _ in 0..20 {
            k.key(Key::TauDown, true);
        }
        assert_eq!(k.tau, 0.0);
        for _ in 0..20 {
            k.key(Key::TauUp, true);
        }
        assert_eq!(k.tau, 50.0);
    }

    #[test]
    fn single_presses_are_actions() {
        let mut k = Controls::new(&start(), 1.0, 0.0);
        assert_eq!(k.key(Key::Do(Action::Record), true), Some(Action::Record));
        assert_eq!(k.key(Key::Do(Action::Record), false), None);
        k.key(Key::Left, true);
        k.release_all();
        let p = k.position;
        k.advance(0.1);
        assert_eq!(k.position, p, "released keys do not move");
    }
}
