//! Cluster configuration (`configs/*.toml`): the scene, the settings every process must agree
//! on, and where each node listens and can be reached. Command-line flags override it.
//!
//! ```toml
//! scene = "out/demo/plant.osw"
//! tau = 1.0
//! size = "1024x1024"
//! batch = 1024
//! token = "secret"            # optional: every connection must present it
//! [nodes.a]
//! listen = "127.0.0.1:7101"   # loopback by default: reachable from this host only
//! address = "127.0.0.1:7101"  # where the peer and the display connect
//! [nodes.b]
//! listen = "127.0.0.1:7102"
//! address = "127.0.0.1:7102"
//! ```

use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub scene: Option<PathBuf>,
    pub tau: Option<f64>,
    pub size: Option<String>,
    pub batch: Option<usize>,
    pub token: Option<String>,
    #[serde(default)]
    pub nodes: BTreeMap<String, NodeAddress>,
}

#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NodeAddress {
    pub listen: String,
    pub address: String,
}

impl Config {
    /// Parses a configuration; errors name what is wrong and where.
    pub fn parse(text: &str) -> Result<Config, String> {
        let c: Config = toml::from_str(text).map_err(|e| e.to_string())?;
        if let Some(n) = c.nodes.keys().find(|n| *n != "a" && *n != "b") {
            return Err(format!("unknown node {n:?}: the nodes are a and b"));
        }
        if c.tau.is_some_and(|t| !(t >= 0.0 && t.is_finite())) {
            return Err(format!("tau {} must be a finite number >= 0", c.tau.unwrap_or_default()));
        }
        Ok(c)
    }

    pub fn load(path: &Path) -> Result<Config, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Config::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Node `name`'s addresses, or an error naming the missing table.
    pub fn node(&self, name: &str) -> Result<&NodeAddress, String> {
        self.nodes.get(name).ok_or_else(|| format!("no [nodes.{name}] table"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_configs_parse() {
        for f in ["local.toml", "three-hosts.toml", "compose.toml"] {
            let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs").join(f);
            let c = Config::load(&p).unwrap_or_else(|e| panic!("{e}"));
            assert!(c.node("a").is_ok() && c.node("b").is_ok(), "{f}");
        }
    }

    #[test]
    fn bad_configs_are_named() {
        assert!(Config::parse("tau = -1").unwrap_err().contains("tau"));
        assert!(Config::parse("[nodes.c]\nlisten = \"x\"\naddress = \"y\"").unwrap_err().contains("unknown node"));
        assert!(Config::parse("colour = 3").is_err());
        assert!(Config::parse("tau = ").is_err());
        assert_eq!(Config::parse("").unwrap().node("a").unwrap_err(), "no [nodes.a] table");
    }
}
