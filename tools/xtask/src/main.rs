//! `cargo xtask`: dynview's build orchestration.
//!
//! - `cargo xtask test`: installs what is missing, then runs every check and test;
//! - `cargo xtask demo [--fresh] [--real]`: installs what is missing, builds, makes the sample
//!   event, prepares it from its videos and serves the viewer with it (`--real`: the Pose2Sim
//!   capture, calibrated and with our SfM);
//! - `cargo xtask eval [--real]`: renderer and full-pipeline quality on the synthetic event, or
//!   leave-one-camera-out on the real capture;
//! - `cargo xtask bench sfm`: our keyframe SfM against COLMAP and ground truth;
//! - `cargo xtask bench prep`: the whole `dynview prep` on a 6-camera, 100-frame event.

mod bench;
mod bench_prep;
mod bench_sfm;
mod bench_web;
mod demo;
mod demo_real;
mod eval;
mod eval_pipeline;
mod eval_real;
mod fixtures;
mod pose2sim;
mod prep_runs;
mod serve;
mod setup;
mod sfm_data;
mod sfm_datasets;
mod sfm_qualisys;
mod sfm_runners;
mod test;
mod util;
mod web;

use anyhow::bail;

const USAGE: &str = "usage: cargo xtask <command>

commands:
  test           install what is missing, then fmt, clippy, all tests, wasm32 build of the core
  serve SCENE [--port N]
                 build the wasm package and serve the viewer with a scene package folder
  e2e            only the page's end-to-end tests (Playwright, headless Chromium)
  demo [--fresh] [--real] [--port N] [--no-serve]
                 install what is missing, build, make the sample event (target/demo/event),
                 run dynview prep on its videos (target/demo/prep) and serve the viewer on
                 127.0.0.1 with the prepared scene (`demo`) and the event's ground-truth
                 package (`demo-truth`); prep skips stages a former run finished, --fresh
                 remakes the event and redoes prep.
                 --real: the Pose2Sim capture (../shared/data/pose2sim-multiperson) prepared
                 with its Qualisys calibration (`pose2sim-calibrated`) and with our own SfM
                 (`pose2sim-sfm`, reported and skipped when it fails), both served
  bench          ms per frame of the full method at 480x270, 960x540 and 1920x1080
                 (release build, all cores), per level and stage
  bench sfm [--dataset NAME]... [--only ours|colmap] [--robust]
                 our keyframe SfM (dynview prep) vs COLMAP on the synthetic event, the
                 Middlebury temple ring and Pose2Sim: time, registered images, reprojection
                 and pose errors against ground truth (target/bench/sfm/results.md)
  bench prep [--out DIR] [--event-only]
                 the whole dynview prep (release) on a 6-camera, 100-frame, 960x540
                 hand-held synthetic event's videos: wall time, stage times, package size,
                 points, pose accuracy (docs/results/prep.md); --event-only makes the
                 event (once) and stops
  bench-web      the viewer in headless Chromium on the demo event: time to first frame,
                 CPU-path ms per frame at 480x270 and 960x540, wasm package size
  eval [--frames N] [--methods a,b] [--params FILE] [--out DIR] [--no-pipeline] [--fresh]
                 quality table of the renderer and its baselines on the synthetic event:
                 from the ground-truth package, and through the full pipeline (dynview prep
                 on the event's videos, with and without densification, aligned to the
                 truth by a similarity); written to docs/results/eval.md. --fresh redoes
                 the prep runs (target/eval/prep*)
  eval --real [--frames N] [--fresh] [--out DIR]
                 leave-one-camera-out on the Pose2Sim capture: each camera rendered from a
                 package of the other three (calibrated poses, first N frames, default 20)
                 and compared with its real frames (docs/results/real.md and strips)";

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(command) = args.first() else {
        println!("{USAGE}");
        return Ok(());
    };
    let rest = &args[1..];
    match command.as_str() {
        "test" => test::run(rest),
        "demo" => demo::run(rest),
        "e2e" => test::run_end_to_end(rest),
        "serve" => demo::serve_scene(rest),
        "bench" if rest.first().is_some_and(|a| a == "sfm") => bench_sfm::run(&rest[1..]),
        "bench" if rest.first().is_some_and(|a| a == "prep") => bench_prep::run(&rest[1..]),
        "bench" => bench::run(rest),
        "bench-release" => bench::run_release(rest),
        "bench-web" => bench_web::run(rest),
        "eval" => eval::run(rest),
        "eval-release" => eval::run_release(rest),
        "help" | "--help" | "-h" => {
            println!("{USAGE}");
            Ok(())
        }
        other => bail!("unknown command {other:?}\n\n{USAGE}"),
    }
}
