//! Cluster configuration TOML: refused with a message, or accepted with a usable tau and only
//! the nodes a and b.

use osw_wire::config::Config;

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(c) = Config::parse(text) else { return };
    assert!(c.tau.is_none_or(|t| t.is_finite() && t >= 0.0), "accepted tau {:?}", c.tau);
    assert!(c.nodes.keys().all(|n| n == "a" || n == "b"));
}
