//! `dynview`: turn synchronized videos of an event into a scene package, inspect it, render
//! novel views of it, make synthetic events with ground truth, and exchange camera poses with
//! COLMAP.

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
    /// Camera poses of every frame from one video or image folder per camera (structure from
    /// motion on keyframes, then frame-to-frame refinement).
    Prep(commands::prep::Args),
    /// Render a camera path (nerfstudio camera_path.json or dynview path) through a scene.
    Render(commands::render::Args),
    /// Convert a COLMAP model (text or binary) into poses.json.
    ImportColmap(commands::colmap::ImportArgs),
    /// Write the cameras and poses of a scene package or a poses.json as a COLMAP model.
    ExportColmap(commands::colmap::ExportArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Synth(args) => commands::synth::run(args),
        Command::Info(args) => commands::info::run(args),
        Command::Render(args) => commands::render::run(args),
        Command::ImportColmap(args) => commands::colmap::run_import(args),
        Command::ExportColmap(args) => commands::colmap::run_export(args),
        Command::Prep(args) => commands::prep::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
