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
            eprintln!("error: {}", error_report(&err));
            std::process::ExitCode::FAILURE
        }
    }
}

/// `err` and its causes joined by `: `, leaving out a cause whose text its error already
/// ends with (library errors often show their source in their own message too).
fn error_report(err: &anyhow::Error) -> String {
    let mut report = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if report.ends_with(&text) {
            continue;
        }
        if !report.is_empty() {
            report.push_str(": ");
        }
        report.push_str(&text);
    }
    report
}

#[cfg(test)]
mod tests {
    use super::error_report;

    /// An error that shows its source in its own message, as `#[error("...: {0}")]` with
    /// `#[from]` does.
    #[derive(Debug)]
    struct Wrapping(std::io::Error);

    impl std::fmt::Display for Wrapping {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "bundle adjustment: {}", self.0)
        }
    }

    impl std::error::Error for Wrapping {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn an_error_report_names_each_cause_once() {
        let inner = std::io::Error::other("the normal equations could not be factorised");
        let err = anyhow::Error::new(Wrapping(inner)).context("dynview prep --input cams");
        assert_eq!(error_report(&err), "dynview prep --input cams: bundle adjustment: the normal equations could not be factorised");
        let plain = anyhow::anyhow!("outer").context("context");
        assert_eq!(error_report(&plain), "context: outer");
    }
}
