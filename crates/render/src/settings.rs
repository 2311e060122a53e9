//! The settings of a switch run that its three processes must share, declared once for
//! `osw run`, `osw-node` and `osw-display` (flags over the cluster configuration over
//! defaults), said in every hello and compared there field by field
//! (osw_wire::net::handshake): two nodes that cull with different thresholds would make frames
//! that depend on which node was HC, and nothing else would notice. `osw run` writes them into
//! the cluster configuration the three processes read.

use osw_cull::cluster::ClusterTests;
use osw_wire::config::Config;

/// The settings as flags; each overrides the configuration's value.
#[derive(clap::Args, Clone, Copy, Debug, Default, PartialEq)]
pub struct AgreedArgs {
    /// Adaptive culling in HC's exact tests (Bartz 1999 eq. 1): boxes whose visible pixels, as a
    /// share of their screen rectangle and discounted by depth, fall below T count as hidden:
    /// time bought with error. 0 is conservative [default: the config's, else 0].
    #[arg(long, value_name = "T")]
    pub adaptive: Option<f64>,
    /// Occlusion culling on every frame, as the papers run it. By default a node that culled
    /// fewer triangles than its culling cost frustum culls only for its next frames (as `osw
    /// render --always-cull`); summary.json's `cull_skipped_frames` counts them [default: the
    /// config's `always_cull`, else off].
    #[arg(long)]
    pub always_cull: bool,
    /// Cluster tests of the passes that draw, in the nodes and the display: as `osw render
    /// --cluster-tests` (`occlusion`: HC's notes of hidden clusters, sent to the display) [default:
    /// the config's, else frustum,cone,backface,small,occlusion].
    #[arg(long, value_name = "LIST")]
    pub cluster_tests: Option<ClusterTests>,
}

/// The settings a run agrees on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Agreed {
    pub adaptive: f64,
    pub always_cull: bool,
    pub cluster_tests: ClusterTests,
}

/// A shared setting that is not valid, named with its value ([`AgreedArgs::resolve`]).
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum SettingsError {
    /// The configuration's `cluster_tests`, and what is wrong with it.
    #[error("cluster_tests {value:?}: {reason}")]
    ClusterTests { value: String, reason: String },
    #[error("--adaptive must be a finite number >= 0, got {0}")]
    Adaptive(f64),
}

impl AgreedArgs {
    /// Flags over `config` over defaults, checked; errors name the setting.
    pub fn resolve(&self, config: &Config) -> Result<Agreed, SettingsError> {
        let cluster_tests = match (self.cluster_tests, &config.cluster_tests) {
            (Some(t), _) => t,
            (None, Some(t)) => t.parse::<ClusterTests>().map_err(|reason| SettingsError::ClusterTests { value: t.clone(), reason })?,
            (None, None) => ClusterTests::default(),
        };
        let adaptive = self.adaptive.or(config.adaptive).unwrap_or(0.0);
        if !(adaptive >= 0.0 && adaptive.is_finite()) {
            return Err(SettingsError::Adaptive(adaptive));
        }
        Ok(Agreed { adaptive, always_cull: self.always_cull || config.always_cull.unwrap_or(false), cluster_tests })
    }
}

impl Agreed {
    /// What a hello says: each setting as its flag and value, with the image size and the
    /// build's shaders (every binary of one build says the same: a node or display left from
    /// another build is refused by name).
    pub fn said(&self, size: (u32, u32)) -> Vec<(String, String)> {
        [
            ("--size", format!("{}x{}", size.0, size.1)),
            ("--adaptive", self.adaptive.to_string()),
            ("--always-cull", self.always_cull.to_string()),
            ("--cluster-tests", self.cluster_tests.to_string()),
            ("shaders (build every binary)", format!("{:016x}", osw_gpu::shaders::FINGERPRINT)),
        ]
        .map(|(k, v)| (k.to_owned(), v))
        .into()
    }

    /// `config` with these settings written into it (`osw run`'s cluster configuration).
    pub fn into_config(self, config: Config) -> Config {
        Config {
            adaptive: Some(self.adaptive),
            always_cull: Some(self.always_cull),
            cluster_tests: Some(self.cluster_tests.to_string()),
            ..config
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        agreed: AgreedArgs,
    }

    fn parse(args: &[&str]) -> AgreedArgs {
        Cli::try_parse_from(std::iter::once("x").chain(args.iter().copied())).unwrap().agreed
    }

    #[test]
    fn flags_override_the_configuration_which_overrides_the_defaults() {
        assert_eq!(parse(&[]).resolve(&Config::default()).unwrap(), Agreed::default());
        let a = Agreed { adaptive: 0.25, always_cull: true, cluster_tests: "frustum,small".parse().unwrap() };
        let written = a.into_config(Config::default());
        assert_eq!(parse(&[]).resolve(&written).unwrap(), a, "the configuration osw run writes gives the settings back");
        let text = written.to_toml();
        assert_eq!(Config::parse(&text).unwrap(), written, "{text}");
        let over = parse(&["--adaptive", "0.5", "--cluster-tests", "cone"]).resolve(&written).unwrap();
        assert_eq!(over, Agreed { adaptive: 0.5, cluster_tests: "cone".parse().unwrap(), ..a });
        assert_eq!(parse(&["--adaptive=-1"]).resolve(&Config::default()), Err(SettingsError::Adaptive(-1.0)));
        let bad = Config { cluster_tests: Some("frustum,colour".into()), ..Config::default() };
        assert!(parse(&[]).resolve(&bad).unwrap_err().to_string().contains("cluster_tests"));
    }
}
