//! `dynview`: turn synchronized videos of an event into a scene package, inspect it, render
//! novel views of it, and make synthetic events with ground truth.

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
    /// Render a camera path (nerfstudio camera_path.json or dynview path) through a scene.
    Render(commands::render::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Synth(args) => commands::synth::run(args),
        Command::Info(args) => commands::info::run(args),
        Command::Render(args) => commands::render::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
