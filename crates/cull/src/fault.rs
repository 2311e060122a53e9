//! Faults for the tests' negative controls: a fault named in `OSW_FAULT` (a comma-separated
//! list) breaks culling on purpose, so that a test can show its references catch it. Compiled
//! in only with the `negative-controls` feature, which only the test that needs it builds (into
//! a target folder of its own): in every other build no environment can turn one on.
//!
//! - `frustum`: the left plane pushed inwards by a quarter of the view's width.
//! - `lod-cut`: LODs selected at four times tau.

#[cfg(feature = "negative-controls")]
pub fn on(name: &str) -> bool {
    static FAULTS: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    FAULTS.get_or_init(|| std::env::var("OSW_FAULT").unwrap_or_default()).split(',').any(|f| f == name)
}

#[cfg(not(feature = "negative-controls"))]
pub const fn on(_: &str) -> bool {
    false
}
