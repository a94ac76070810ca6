//! `cargo xtask`: dynview's build orchestration.
//!
//! - `cargo xtask test`: installs what is missing, then runs every check and test;
//! - `cargo xtask demo [--fresh]`: installs what is missing, builds, makes the sample event and
//!   serves the viewer with it;
//! - `cargo xtask bench sfm`: our keyframe SfM against COLMAP and ground truth.

mod bench;
mod bench_sfm;
mod bench_web;
mod demo;
mod eval;
mod fixtures;
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
  demo [--fresh] [--port N] [--no-serve]
                 install what is missing, build, make the sample event and serve the
                 viewer on 127.0.0.1 (--fresh regenerates the event even if it exists)
  bench          ms per frame of the full method at 480x270, 960x540 and 1920x1080
                 (release build, all cores), per level and stage
  bench sfm [--dataset NAME]... [--only ours|colmap] [--robust]
                 our keyframe SfM (dynview prep) vs COLMAP on the synthetic event, the
                 Middlebury temple ring and Pose2Sim: time, registered images, reprojection
                 and pose errors against ground truth (target/bench/sfm/results.md)
  bench-web      the viewer in headless Chromium on the demo event: time to first frame,
                 CPU-path ms per frame at 480x270 and 960x540, wasm package size
  eval [--frames N] [--params FILE] [--out DIR]
                 quality table of the renderer and its baselines on the synthetic event
                 (written to docs/results/)";

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
