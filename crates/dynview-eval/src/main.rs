//! `dynview-eval`: the evaluations and benchmarks (run through `cargo xtask eval` and
//! `cargo xtask bench`, which build it and `dynview` in release mode first).

use clap::{Parser, Subcommand};
use dynview_eval::{bench, eval};

/// dynview's evaluations and benchmarks; results go to `docs/results/` or `target/bench/`.
#[derive(Parser)]
#[command(name = "dynview-eval", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Quality of the renderer and its baselines on the synthetic event's held-out cameras,
    /// from the ground-truth package and through the full pipeline (`docs/results/eval.md`).
    Eval(eval::scoring::Options),
    /// Leave-one-camera-out on the real captures, Panoptic's two arcs and Pose2Sim's lab,
    /// scored raw and colour-corrected, over whole frames and their static and moving pixels
    /// (`docs/results/real.md`).
    EvalReal(eval::real::Options),
    /// Milliseconds per frame of the full method (at 480x270, 960x540 and 1920x1080 unless
    /// told), per level and stage, on the CPU and on the GPU wgpu finds.
    Bench(bench::render::Options),
    /// The whole `dynview prep` on a 6-camera, 100-frame, 960x540 hand-held event
    /// (`docs/results/prep.md`).
    BenchPrep(bench::prep::Options),
    /// Our keyframe SfM against COLMAP on synthetic events (four layouts), the temple ring,
    /// Pose2Sim and the Panoptic arc (`target/bench/sfm/results.md`).
    BenchSfm(bench::sfm::Options),
}

fn main() -> std::process::ExitCode {
    let result = match Cli::parse().command {
        Command::Eval(options) => eval::synthetic::run(options),
        Command::EvalReal(options) if options.unsync => eval::real::unsync::run(options),
        Command::EvalReal(options) if options.own_poses => eval::real::own_poses::run(options),
        Command::EvalReal(options) => eval::real::run(options),
        Command::Bench(options) => bench::render::run(options),
        Command::BenchPrep(options) => bench::prep::run(options),
        Command::BenchSfm(options) => bench::sfm::run(options),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("dynview-eval: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
