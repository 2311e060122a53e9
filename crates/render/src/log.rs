//! Logging for the three binaries (osw, osw-node, osw-display): to stderr, at the level in
//! `OSW_LOG` (tracing's filter syntax), warnings by default.

pub fn init() {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_env("OSW_LOG").unwrap_or_else(|_| "warn".into()))
        .init();
}
