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

/// One line of a path file, by the header's names.
#[derive(serde::Serialize, serde::Deserialize)]
struct Row {
    frame: u64,
    px: f64,
    py: f64,
    pz: f64,
    qx: f64,
    qy: f64,
    qz: f64,
    qw: f64,
    fovy_deg: f64,
}

/// Formats cameras as path CSV.
pub fn to_csv(cameras: &[Camera]) -> String {
    let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::with_capacity(64 * (cameras.len() + 1)));
    for (i, c) in cameras.iter().enumerate() {
        let (p, q) = (c.position, c.orientation);
        let row = Row { frame: i as u64, px: p.x, py: p.y, pz: p.z, qx: q.x, qy: q.y, qz: q.z, qw: q.w, fovy_deg: c.fovy_deg };
        // Numbers into a Vec: the writes cannot fail.
        w.serialize(row).expect("a row of numbers serialises");
    }
    // The csv crate writes each f64 as the shortest text that reads back to the same value.
    let rows = String::from_utf8(w.into_inner().expect("a Vec takes every write")).expect("CSV of numbers");
    format!("{HEADER}\n{rows}")
}

/// Parses path CSV; `name` is used in error messages.
pub fn parse_csv(text: &str, name: &str) -> Result<Vec<Camera>, PathError> {
    let bad = |line: u64, what: String| PathError::Bad { path: name.to_owned(), line: line as usize, what };
    let mut r = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(text.as_bytes());
    let headers = r.headers().map_err(|e| bad(1, e.to_string()))?.clone();
    let line_of = |e: &csv::Error| e.position().map_or(0, |p| p.line());
    match headers.iter().collect::<Vec<_>>().join(",") {
        h if h == HEADER => {}
        h if h.is_empty() => return Err(bad(1, "empty file: expected the header line and at least one camera".into())),
        h => return Err(bad(headers.position().map_or(1, |p| p.line()), format!("header {h:?}, expected {HEADER:?}"))),
    }
    let mut out = Vec::new();
    let mut record = csv::StringRecord::new();
    loop {
        let read = r.read_record(&mut record).map_err(|e| match e.kind() {
            csv::ErrorKind::UnequalLengths { len, .. } => bad(line_of(&e), format!("{len} fields, expected 9")),
            _ => bad(line_of(&e), e.to_string()),
        })?;
        if !read {
            break;
        }
        let line = record.position().map_or(0, |p| p.line());
        let row: Row = record.deserialize(Some(&headers)).map_err(|e| match e.kind() {
            csv::ErrorKind::Deserialize { err, .. } => {
                let field = err.field().map_or(String::new(), |k| format!("field {} ", k + 1));
                bad(line, format!("{field}is not a number: {}", err.kind()))
            }
            _ => bad(line, e.to_string()),
        })?;
        if row.frame != out.len() as u64 {
            return Err(bad(line, format!("frame {}, expected {}", row.frame, out.len())));
        }
        let cam = Camera {
            position: DVec3::new(row.px, row.py, row.pz),
            orientation: DQuat::from_xyzw(row.qx, row.qy, row.qz, row.qw),
            fovy_deg: row.fovy_deg,
        };
        out.push(cam.validated().map_err(|e| bad(line, e.to_string()))?);
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
