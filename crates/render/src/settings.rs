//! The settings of a switch run that its three processes must share, declared once for
//! `osw run`, `osw-node` and `osw-display`, said in every hello and compared there field by
//! field (osw_wire::net::handshake): two nodes that cull with different thresholds would make
//! frames that depend on which node was HC, and nothing else would notice.

use osw_cull::cluster::ClusterTests;

#[derive(clap::Args, Clone, Copy, Debug, Default, PartialEq)]
pub struct Agreed {
    /// Adaptive culling in HC's exact tests (Bartz 1999 eq. 1): boxes whose visible pixels, as a
    /// share of their screen rectangle and discounted by depth, fall below T count as hidden:
    /// time bought with error. 0 is conservative.
    #[arg(long, default_value_t = 0.0, value_name = "T")]
    pub adaptive: f64,
    /// Occlusion culling on every frame, as the papers run it. By default a node that culled
    /// fewer triangles than its culling cost frustum culls only for its next frames (as `osw
    /// render --always-cull`); summary.json's `cull_skipped_frames` counts them.
    #[arg(long)]
    pub always_cull: bool,
    /// Cluster tests of the passes that draw, in the nodes and the display: as `osw render
    /// --cluster-tests` (`occlusion` is RVG's two passes, in the display).
    #[arg(long, default_value_t = ClusterTests::default(), value_name = "LIST")]
    pub cluster_tests: ClusterTests,
}

impl Agreed {
    pub fn check(&self) -> Result<(), String> {
        if !(self.adaptive >= 0.0 && self.adaptive.is_finite()) {
            return Err(format!("--adaptive must be a finite number >= 0, got {}", self.adaptive));
        }
        Ok(())
    }

    /// What a hello says: each setting as its flag and value, with the image size.
    pub fn said(&self, size: (u32, u32)) -> Vec<(String, String)> {
        [
            ("--size", format!("{}x{}", size.0, size.1)),
            ("--adaptive", self.adaptive.to_string()),
            ("--always-cull", self.always_cull.to_string()),
            ("--cluster-tests", self.cluster_tests.to_string()),
        ]
        .map(|(k, v)| (k.to_owned(), v))
        .into()
    }

    /// The flags that give these settings to a process (`osw run` starting the cluster).
    pub fn args(&self) -> Vec<String> {
        let mut v = vec!["--adaptive".into(), self.adaptive.to_string(), "--cluster-tests".into(), self.cluster_tests.to_string()];
        if self.always_cull {
            v.push("--always-cull".into());
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        agreed: Agreed,
    }

    #[test]
    fn the_flags_give_back_the_settings() {
        let a = Agreed { adaptive: 0.25, always_cull: true, cluster_tests: "frustum,small".parse().unwrap() };
        let back = Cli::try_parse_from(std::iter::once("x".to_string()).chain(a.args())).unwrap().agreed;
        assert_eq!(back, a);
        assert_eq!(back.said((4, 3)), a.said((4, 3)));
        assert_eq!(Cli::try_parse_from(["x"]).unwrap().agreed, Agreed::default(), "the defaults");
    }
}
