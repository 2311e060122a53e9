//! Camera paths: the CSV every tool reads and writes.
//!
//! ```text
//! frame,px,py,pz,qx,qy,qz,qw,fovy_deg
//! 0,12.5,1.8,40.25,0,0.382683,0,0.92388,60
//! ```
//! Positions are world units (f64 text, full precision); the quaternion follows
//! [`crate::camera`]'s convention; frames count up from 0 without gaps.

use crate::camera::Camera;
use glam::{DQuat, DVec3};
use std::fmt::Write as _;
use std::path::Path;

pub const HEADER: &str = "frame,px,py,pz,qx,qy,qz,qw,fovy_deg";

/// A path file that cannot be used; the message names the line.
#[derive(Debug, thiserror::Error)]
pub enum PathError {
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}:{line}: {what}")]
    Bad { path: String, line: usize, what: String },
}

/// Formats cameras as path CSV.
pub fn to_csv(cameras: &[Camera]) -> String {
    let mut s = String::with_capacity(64 * (cameras.len() + 1));
    s.push_str(HEADER);
    s.push('\n');
    for (i, c) in cameras.iter().enumerate() {
        let (p, q) = (c.position, c.orientation);
        // `{}` on f64 prints the shortest text that reads back to the same value.
        let _ = writeln!(s, "{i},{},{},{},{},{},{},{},{}", p.x, p.y, p.z, q.x, q.y, q.z, q.w, c.fovy_deg);
    }
    s
}

/// Parses path CSV; `name` is used in error messages.
pub fn parse_csv(text: &str, name: &str) -> Result<Vec<Camera>, PathError> {
    let bad = |line: usize, what: String| PathError::Bad { path: name.to_owned(), line, what };
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    match lines.next() {
        Some((_, h)) if h.trim() == HEADER => {}
        Some((i, h)) => return Err(bad(i + 1, format!("header {h:?}, expected {HEADER:?}"))),
        None => return Err(bad(1, "empty file: expected the header line and at least one camera".into())),
    }
    let mut out = Vec::new();
    for (i, line) in lines {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 9 {
            return Err(bad(i + 1, format!("{} fields, expected 9", f.len())));
        }
        let frame: u64 = f[0].parse().map_err(|_| bad(i + 1, format!("frame {:?} is not a whole number", f[0])))?;
        if frame != out.len() as u64 {
            return Err(bad(i + 1, format!("frame {frame}, expected {}", out.len())));
        }
        let mut v = [0f64; 8];
        for (k, s) in f[1..].iter().enumerate() {
            v[k] = s.parse().map_err(|_| bad(i + 1, format!("field {} ({s:?}) is not a number", k + 2)))?;
        }
        let cam = Camera { position: DVec3::new(v[0], v[1], v[2]), orientation: DQuat::from_xyzw(v[3], v[4], v[5], v[6]), fovy_deg: v[7] };
        out.push(cam.validated().map_err(|e| bad(i + 1, e))?);
    }
    if out.is_empty() {
        return Err(bad(1, "no cameras after the header".into()));
    }
    Ok(out)
}

pub fn read(path: &Path) -> Result<Vec<Camera>, PathError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| PathError::Io { path: name.clone(), source })?;
    parse_csv(&text, &name)
}

pub fn write(path: &Path, cameras: &[Camera]) -> Result<(), PathError> {
    std::fs::write(path, to_csv(cameras)).map_err(|source| PathError::Io { path: path.display().to_string(), source })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn round_trip_is_exact(x in -1e8f64..1e8, y in -1e3f64..1e3, z in -1e8f64..1e8, yaw in -3.2f64..3.2, fov in 1.0f64..170.0) {
            let c = Camera { position: DVec3::new(x, y, z), orientation: DQuat::from_rotation_y(yaw), fovy_deg: fov };
            let back = parse_csv(&to_csv(&[c, c]), "p").unwrap();
            prop_assert_eq!(back.len(), 2);
            prop_assert_eq!(back[0].position, c.position);
            prop_assert!((back[0].orientation.dot(c.orientation) - 1.0).abs() < 1e-12);
            prop_assert_eq!(back[0].fovy_deg, fov);
        }

        #[test]
        fn garbage_never_panics(s in "\\PC{0,200}") {
            let _ = parse_csv(&s, "p");
            let _ = parse_csv(&format!("{HEADER}\n{s}"), "p");
        }
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse_csv(&format!("{HEADER}\n0,1,2,3,0,0,0,1,60\n1,nan,2,3,0,0,0,1,60\n"), "p.csv").unwrap_err();
        assert!(e.to_string().starts_with("p.csv:3:"), "{e}");
        let e = parse_csv(&format!("{HEADER}\n0,1,2,3,0,0,0,1,60\n2,1,2,3,0,0,0,1,60\n"), "p.csv").unwrap_err();
        assert!(e.to_string().contains("expected 1"), "{e}");
        assert!(parse_csv("frame,x\n", "p").is_err());
        assert!(parse_csv(&format!("{HEADER}\n0,1,2,3,0,0,0,0,60\n"), "p").is_err());
        assert!(parse_csv(&format!("{HEADER}\n0,1,2,3,0,0,0,1,200\n"), "p").is_err());
        assert!(parse_csv(&format!("{HEADER}\n"), "p").is_err());
    }
}
