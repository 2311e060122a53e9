//! `osw`: the osw tool. Subcommands build scenes, make camera paths and inspect scene files;
//! later issues add render, exact, compare, run and report here.
//!
//! Exit codes: 0 success, 1 error (message on stderr, prefixed `osw: error:`), 2 bad usage.

mod cmd_build;
mod cmd_info;
mod cmd_path;
mod progress;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "osw", version, about = "occlusion-switch walkthroughs of massive models", long_about = None)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Build a scene file from a glTF/GLB/PLY file or a generator.
    Build(cmd_build::Args),
    /// Make a camera path (CSV) through a scene.
    Path(cmd_path::Args),
    /// Open a scene file, validate it and print what it holds.
    Info(cmd_info::Args),
}

fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_env("OSW_LOG").unwrap_or_else(|_| "warn".into()))
        .init();
    let cli = Cli::parse();
    let r = match cli.cmd {
        Cmd::Build(a) => cmd_build::run(a),
        Cmd::Path(a) => cmd_path::run(a),
        Cmd::Info(a) => cmd_info::run(a),
    };
    match r {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("osw: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
