//! `osw`: the osw tool. Subcommands build scenes, make camera paths, inspect scene files,
//! render paths with each culling mode, compute exact visibility and compare runs.
//!
//! Exit codes: 0 success, 1 error (message on stderr, prefixed `osw: error:`), 2 bad usage.

/// `println!` that never panics: a closed stdout (`osw ... | head`) is not an error of osw's.
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

mod cmd_bandwidth;
mod cmd_build;
mod cmd_certs;
mod cmd_compare;
mod cmd_exact;
mod cmd_info;
mod cmd_latency;
mod cmd_link;
mod cmd_path;
mod cmd_plot;
mod cmd_render;
mod cmd_report;
mod cmd_run;
mod cmd_scale;
mod plot;
mod progress;
mod scale_report;
mod walk_args;

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
    /// Render a camera path with one culling mode (single process).
    Render(cmd_render::Args),
    /// Exact visibility (item buffer at full detail) for every frame of a path.
    Exact(cmd_exact::Args),
    /// Image and culling error of one run against another and against exact visibility.
    Compare(cmd_compare::Args),
    /// Run the occlusion switch on this host: two nodes and the display, three processes.
    Run(cmd_run::Args),
    /// Replay a camera path in a window (`osw run --window`): e.g. a path recorded in a walk
    /// (`osw run --interactive`, key R).
    Play(cmd_run::Args),
    /// Error against run time: every mode at every tau, compared with exact visibility and
    /// full-detail images; report.md, report.json and a plot.
    Report(cmd_report::Args),
    /// A frame's cost against the model's size: the generated plant at each size, every mode
    /// at every tau; scale.md, scale.json and a log-log plot.
    Scale(cmd_scale::Args),
    /// Bytes and ids per frame on each link of a switch run, against occlusion switch's model.
    Bandwidth(cmd_bandwidth::Args),
    /// One-way latency per link and camera-to-display latency of a switch run.
    Latency(cmd_latency::Args),
    /// A TCP relay that delays and loses like a lossy network (for kernels without netem):
    /// put one in front of a node and point its peer and the display at it.
    Link(cmd_link::Args),
    /// A cluster's own CA and a certificate for each process, for mutual TLS on every link.
    Certs(cmd_certs::Args),
    /// Columns of a CSV file against one of them, as PNG and SVG (the scripts' tables).
    Plot(cmd_plot::Args),
}

fn main() -> std::process::ExitCode {
    osw_gpu::device::quiet_device_select();
    osw_render::log::init();
    let cli = Cli::parse();
    let r = match cli.cmd {
        Cmd::Build(a) => cmd_build::run(a),
        Cmd::Path(a) => cmd_path::run(a),
        Cmd::Info(a) => cmd_info::run(a),
        Cmd::Render(a) => cmd_render::run(a),
        Cmd::Exact(a) => cmd_exact::run(a),
        Cmd::Compare(a) => cmd_compare::run(a),
        Cmd::Run(a) => cmd_run::run(a),
        Cmd::Play(a) => cmd_run::play(a),
        Cmd::Report(a) => cmd_report::run(a),
        Cmd::Scale(a) => cmd_scale::run(a),
        Cmd::Bandwidth(a) => cmd_bandwidth::run(a),
        Cmd::Latency(a) => cmd_latency::run(a),
        Cmd::Link(a) => cmd_link::run(a),
        Cmd::Certs(a) => cmd_certs::run(a),
        Cmd::Plot(a) => cmd_plot::run(a),
    };
    match r {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("osw: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
