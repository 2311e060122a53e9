//! Cluster configuration (`configs/*.toml`): the scene, the settings every process must agree
//! on, and where each node listens and can be reached. Command-line flags override it.
//!
//! ```toml
//! scene = "out/demo/plant.osw"
//! tau = 1.0
//! size = "1024x1024"
//! batch = 1024
//! token_file = "cluster.key"  # optional: every connection must prove it holds this secret
//!                             # (or token = "..."; a file keeps it out of `ps` and of the config)
//! tls_cert = "certs/node-a.pem"  # optional, all three or none: mutual TLS on every link
//! tls_key = "certs/node-a.key"   # (`osw certs` makes a cluster's; a config per process)
//! tls_ca = "certs/ca.pem"
//! adaptive = 0.0              # the settings every process must agree on (`osw run` writes
//! always_cull = false         # them; each process's flags override them)
//! cluster_tests = "frustum,cone,backface,small,occlusion"
//! [nodes.a]
//! listen = "127.0.0.1:7101"   # loopback by default: reachable from this host only
//! address = "127.0.0.1:7101"  # where the peer and the display connect
//! [nodes.b]
//! listen = "127.0.0.1:7102"
//! address = "127.0.0.1:7102"
//! ```

use crate::auth::Token;
use crate::limits::DEFAULT_BATCH_IDS;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The flags every cluster process takes; each overrides the configuration's value.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ClusterArgs {
    /// Cluster configuration (configs/*.toml); the flags below override it.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Scene file: the same file, by content hash, in every process [default: the config's].
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Pixels of error for LOD selection; the display sends it with every camera, so its value
    /// is the one the nodes use [default: the config's, else 0].
    #[arg(long)]
    pub tau: Option<f64>,
    /// Image size, WIDTHxHEIGHT [default: the config's, else 1024x1024].
    #[arg(long)]
    pub size: Option<String>,
    /// Ids per delta batch, the paper's b [default: the config's, else 1024].
    #[arg(long)]
    pub batch: Option<usize>,
    /// Shared cluster token: every connection must prove it holds it (it is never sent). Shows
    /// in `ps`: prefer --token-file [default: the config's, if any].
    #[arg(long, conflicts_with = "token_file")]
    pub token: Option<String>,
    /// File holding the cluster token (its first line) [default: the config's, if any].
    #[arg(long, value_name = "PATH")]
    pub token_file: Option<PathBuf>,
    /// This process's certificate (PEM, signed by the cluster's CA; `osw certs` makes them):
    /// every link in mutual TLS [default: the config's, if any; with --tls-key and --tls-ca].
    #[arg(long, value_name = "PEM", requires_all = ["tls_key", "tls_ca"])]
    pub tls_cert: Option<PathBuf>,
    /// This process's private key (PEM).
    #[arg(long, value_name = "PEM", requires_all = ["tls_cert", "tls_ca"])]
    pub tls_key: Option<PathBuf>,
    /// The cluster's CA certificate (PEM): only peers it signed are admitted.
    #[arg(long, value_name = "PEM", requires_all = ["tls_cert", "tls_key"])]
    pub tls_ca: Option<PathBuf>,
    /// Adapter: the first whose name contains this text [default: a GPU, else lavapipe].
    #[arg(long)]
    pub adapter: Option<String>,
}

/// [`ClusterArgs`] resolved: flags over the configuration over defaults, checked.
#[derive(Clone, Debug)]
pub struct Settings {
    pub config: Config,
    pub scene: PathBuf,
    pub tau: f64,
    pub size: (u32, u32),
    pub batch: usize,
    pub token: Option<Token>,
    pub tls: Option<TlsFiles>,
}

/// Where a process's certificate, its key and the cluster's CA certificate are (PEM).
#[derive(Clone, Debug, PartialEq)]
pub struct TlsFiles {
    pub cert: PathBuf,
    pub key: PathBuf,
    pub ca: PathBuf,
}

impl ClusterArgs {
    pub fn resolve(&self) -> Result<Settings, ConfigError> {
        let config = match &self.config {
            Some(p) => Config::load(p)?,
            None => Config::default(),
        };
        let scene = self.scene.clone().or(config.scene.clone()).ok_or(ConfigError::NoScene)?;
        let tau = self.tau.or(config.tau).unwrap_or(0.0);
        if !(tau >= 0.0 && tau.is_finite()) {
            return Err(ConfigError::Invalid(format!("--tau {tau}: expected a finite number >= 0")));
        }
        let batch = self.batch.or(config.batch).unwrap_or(DEFAULT_BATCH_IDS);
        if batch == 0 {
            return Err(ConfigError::Invalid("--batch must be at least 1".into()));
        }
        let size = self.size.clone().or(config.size.clone()).unwrap_or_else(|| "1024x1024".into());
        let size = size
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
            .ok_or_else(|| ConfigError::Invalid(format!("--size {size:?}: expected WIDTHxHEIGHT")))?;
        let token = match (&self.token, &self.token_file) {
            (Some(t), _) => Some(t.clone()),
            (None, Some(p)) => Some(read_token(p)?),
            (None, None) => match (&config.token, &config.token_file) {
                (Some(t), _) => Some(t.clone()),
                (None, Some(p)) => Some(read_token(p)?),
                (None, None) => None,
            },
        };
        let tls = match (&self.tls_cert, &self.tls_key, &self.tls_ca) {
            (Some(cert), Some(key), Some(ca)) => Some(TlsFiles { cert: cert.clone(), key: key.clone(), ca: ca.clone() }),
            _ => match (&config.tls_cert, &config.tls_key, &config.tls_ca) {
                (Some(cert), Some(key), Some(ca)) => Some(TlsFiles { cert: cert.clone(), key: key.clone(), ca: ca.clone() }),
                (None, None, None) => None,
                _ => return Err(ConfigError::Invalid("tls_cert, tls_key and tls_ca go together".into())),
            },
        };
        Ok(Settings { config, scene, tau, size, batch, token: token.map(checked_token).transpose()?, tls })
    }
}

/// The example configurations' stand-in for a secret: refused, so that a cluster never runs
/// on a token anyone can read.
pub const PLACEHOLDER_TOKEN: &str = "replace with a shared secret";

/// The first line of the token file `path`.
fn read_token(path: &Path) -> Result<String, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io { path: path.to_owned(), source })?;
    Ok(text.lines().next().unwrap_or("").trim().to_owned())
}

/// A token that can serve as a secret: not empty, not the examples' placeholder.
fn checked_token(t: String) -> Result<Token, ConfigError> {
    if t.is_empty() {
        return Err(ConfigError::Invalid("the cluster token is empty".into()));
    }
    if t == PLACEHOLDER_TOKEN {
        return Err(ConfigError::Invalid(format!(
            "the cluster token is the example's placeholder {PLACEHOLDER_TOKEN:?}: set a secret of your own (e.g. `head -c 32 /dev/urandom | base64 > cluster.key` and token_file = \"cluster.key\")"
        )));
    }
    Ok(Token::new(t))
}

/// A cluster configuration that cannot be read, or a setting of it or of the flags that is not
/// valid; each names the file or the setting.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// What is wrong with the configuration in a file.
    #[error("{}", path.display())]
    File {
        path: PathBuf,
        #[source]
        source: Box<ConfigError>,
    },
    /// Not TOML, or keys and values that are not a configuration's.
    #[error(transparent)]
    Toml(#[from] toml::de::Error),
    /// A setting out of range, named with its value.
    #[error("{0}")]
    Invalid(String),
    #[error("no scene: give --scene or a config with scene = ...")]
    NoScene,
    #[error("no [nodes.{0}] table")]
    NoNode(String),
}

#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub scene: Option<PathBuf>,
    pub tau: Option<f64>,
    pub size: Option<String>,
    pub batch: Option<usize>,
    pub token: Option<String>,
    pub token_file: Option<PathBuf>,
    /// Mutual TLS: this process's certificate and key, the cluster's CA (all three or none).
    pub tls_cert: Option<PathBuf>,
    pub tls_key: Option<PathBuf>,
    pub tls_ca: Option<PathBuf>,
    /// The settings every process must agree on (`osw_render::settings`): adaptive culling's
    /// threshold, occlusion culling on every frame, the cluster tests.
    pub adaptive: Option<f64>,
    pub always_cull: Option<bool>,
    pub cluster_tests: Option<String>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub nodes: BTreeMap<String, NodeAddress>,
}

#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NodeAddress {
    pub listen: String,
    pub address: String,
}

impl Config {
    /// Parses a configuration; errors name what is wrong and where.
    pub fn parse(text: &str) -> Result<Config, ConfigError> {
        let c: Config = toml::from_str(text)?;
        if let Some(n) = c.nodes.keys().find(|n| *n != "a" && *n != "b") {
            return Err(ConfigError::Invalid(format!("unknown node {n:?}: the nodes are a and b")));
        }
        if c.tau.is_some_and(|t| !(t >= 0.0 && t.is_finite())) {
            return Err(ConfigError::Invalid(format!("tau {} must be a finite number >= 0", c.tau.unwrap_or_default())));
        }
        Ok(c)
    }

    /// The configuration as TOML, as [`Config::parse`] reads it.
    pub fn to_toml(&self) -> String {
        // Paths, numbers and strings: every field has a TOML form.
        toml::to_string(self).expect("a configuration serialises")
    }

    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io { path: path.to_path_buf(), source })?;
        Config::parse(&text).map_err(|e| ConfigError::File { path: path.to_path_buf(), source: Box::new(e) })
    }

    /// Node `name`'s addresses, or an error naming the missing table.
    pub fn node(&self, name: &str) -> Result<&NodeAddress, ConfigError> {
        self.nodes.get(name).ok_or_else(|| ConfigError::NoNode(name.to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_configs_parse() {
        for f in ["local.toml", "three-hosts.toml", "compose.toml"] {
            let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs").join(f);
            let c = Config::load(&p).unwrap_or_else(|e| panic!("{e:?}"));
            assert!(c.node("a").is_ok() && c.node("b").is_ok(), "{f}");
        }
    }

    #[test]
    fn a_token_comes_from_a_file_and_the_placeholder_or_an_empty_one_is_refused() {
        let file = std::env::temp_dir().join(format!("osw-token-test-{}.key", std::process::id()));
        std::fs::write(&file, "from-the-file\nsecond line\n").unwrap();
        let args = |token: Option<&str>, token_file: Option<&Path>| ClusterArgs {
            scene: Some("s.osw".into()),
            token: token.map(str::to_owned),
            token_file: token_file.map(Path::to_owned),
            ..Default::default()
        };
        let resolved = args(None, Some(&file)).resolve().unwrap();
        assert_eq!(resolved.token, Some(Token::new("from-the-file")));
        assert_eq!(args(Some("flag"), None).resolve().unwrap().token, Some(Token::new("flag")));
        let e = args(Some(PLACEHOLDER_TOKEN), None).resolve().unwrap_err().to_string();
        assert!(e.contains("placeholder"), "{e}");
        assert!(args(Some(""), None).resolve().unwrap_err().to_string().contains("empty"));
        let missing = file.with_extension("missing");
        assert!(args(None, Some(&missing)).resolve().unwrap_err().to_string().contains("missing"));
        std::fs::remove_file(&file).unwrap();
        assert_eq!(args(None, None).resolve().unwrap().token, None);
    }

    #[test]
    fn bad_configs_are_named() {
        assert!(Config::parse("tau = -1").unwrap_err().to_string().contains("tau"));
        assert!(Config::parse("[nodes.c]\nlisten = \"x\"\naddress = \"y\"").unwrap_err().to_string().contains("unknown node"));
        assert!(Config::parse("colour = 3").is_err());
        assert!(Config::parse("tau = ").is_err());
        assert_eq!(Config::parse("").unwrap().node("a").unwrap_err().to_string(), "no [nodes.a] table");
    }
}
