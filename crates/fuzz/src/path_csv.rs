//! Camera path CSV: accepted cameras are finite, unit-orientation, with a usable field of view,
//! and write back to text that reads to the same cameras.

use osw_scene::path::{parse_csv, to_csv};

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(cams) = parse_csv(text, "fuzz.csv") else { return };
    for c in &cams {
        assert!(c.position.is_finite() && c.orientation.is_finite());
        assert!((c.orientation.length() - 1.0).abs() < 1e-9, "orientation not normalised");
        assert!(c.fovy_deg > 0.0 && c.fovy_deg < 180.0);
    }
    let again = parse_csv(&to_csv(&cams), "again.csv").expect("a written path reads back");
    assert_eq!(again.len(), cams.len());
    for (a, b) in cams.iter().zip(&again) {
        assert_eq!(a.position, b.position);
        assert!(a.orientation.abs_diff_eq(b.orientation, 1e-12) && a.fovy_deg == b.fovy_deg);
    }
}
