//! `dynview`: turn synchronized videos of an event into a scene package, inspect it, render
//! novel views of it, make synthetic events with ground truth, and exchange camera poses with
//! COLMAP.
//!
//! `prep` and `merge` need OpenCV and come with the default `prep` feature;
//! `cargo build -p dynview-cli --no-default-features` gives a binary without OpenCV that
//! renders, inspects, converts and synthesises.

mod commands;
mod progress;

use clap::{Parser, Subcommand};

/// dynview: free-viewpoint video of live events from a few cameras.
#[derive(Parser, Debug)]
#[command(name = "dynview", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a synthetic dynamic event with ground truth (frames, videos, poses, package).
    Synth(commands::synth::Args),
    /// Check a scene package and print its cameras, time steps, points and size.
    Info(commands::info::Args),
    /// A scene package from one video or image folder per camera: camera poses (structure from
    /// motion on keyframes, frame-to-frame refinement), per-timestep points, densification.
    #[cfg(feature = "prep")]
    Prep(commands::prep::Args),
    /// Join the outputs of range runs (`prep --frames A..B`) into one scene package.
    #[cfg(feature = "prep")]
    Merge(commands::merge::MergeArgs),
    /// Write one time step's cloud of a scene package as a PLY file.
    ExportPly(commands::package::PlyArgs),
    /// Rewrite a scene package with its frames as video (format v2) or as JPEG files.
    Repack(commands::package::RepackArgs),
    /// Render a camera path (nerfstudio camera_path.json or dynview path) through a scene.
    Render(commands::render::Args),
    /// Convert a calibration (COLMAP model, Qualisys .qca.txt, Middlebury *_par.txt) into
    /// poses.json.
    #[command(alias = "import-colmap")]
    Import(commands::colmap::ImportArgs),
    /// Write the cameras and poses of a scene package or a poses.json as a COLMAP model.
    ExportColmap(commands::colmap::ExportArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Synth(args) => commands::synth::run(args),
        Command::Info(args) => commands::info::run(args),
        Command::Render(args) => commands::render::run(args),
        Command::Import(args) => commands::colmap::run_import(args),
        Command::ExportColmap(args) => commands::colmap::run_export(args),
        #[cfg(feature = "prep")]
        Command::Prep(args) => commands::prep::run(args),
        #[cfg(feature = "prep")]
        Command::Merge(args) => commands::merge::run_merge(args),
        Command::ExportPly(args) => commands::package::run_ply(args),
        Command::Repack(args) => commands::package::run_repack(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
