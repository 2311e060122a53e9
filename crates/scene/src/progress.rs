//! Progress of long work (a build, a walk's floors), and whether the user asked to stop.

/// Progress of long work, reported per stage, and whether the user asked to stop. `()`
/// reports nothing and never stops.
pub trait Progress: Sync {
    fn stage(&self, name: &str, total: u64);
    fn advance(&self, n: u64);
    fn cancelled(&self) -> bool {
        false
    }
}

impl Progress for () {
    fn stage(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
}
