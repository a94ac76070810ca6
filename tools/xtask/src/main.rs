//! `cargo xtask`: dynview's build orchestration. It installs what is missing, builds, tests,
//! serves and runs the evaluation binary; the evaluations and benchmarks themselves live in
//! `crates/dynview-eval` (the `dynview-eval` binary, run here in release mode).

mod bench_web;
mod circles;
mod demo;
mod demo_real;
mod dynview_prep;
mod fixtures;
mod serve;
mod setup;
mod test;
mod util;
mod web;

use std::ffi::OsString;
use std::process::Command;

use clap::{Parser, Subcommand};

use crate::util::{cargo, run_step, workspace_root};

/// dynview's build orchestration: `cargo xtask demo` and `cargo xtask test` set up a fresh
/// Debian machine and run everything.
#[derive(Parser)]
#[command(name = "cargo xtask", bin_name = "cargo xtask")]
struct Cli {
    #[command(subcommand)]
    command: Task,
}

#[derive(Subcommand)]
enum Task {
    /// Install what is missing, then fmt, clippy, every native test, the wasm tests in headless
    /// Chromium (wasm-pack) and the page's unit and end-to-end tests.
    Test,
    /// Only the page's end-to-end tests (Playwright, headless Chromium).
    E2e,
    /// Check that no crate (and not the page) has an import circle between its files.
    Circles,
    /// Install what is missing, build, make the sample event (target/demo/event), run dynview
    /// prep on its videos (target/demo/prep) and serve the viewer on 127.0.0.1 with the prepared
    /// scene (`demo`) and the event's ground-truth package (`demo-truth`).
    Demo(demo::DemoArgs),
    /// Build the wasm package and serve the viewer with a scene package folder.
    Serve(demo::ServeArgs),
    /// Quality of the renderer and its baselines on the synthetic event (`dynview-eval eval`,
    /// release build); with `--real`, leave-one-camera-out on the real captures (Panoptic, Pose2Sim)
    /// (`dynview-eval eval-real`). The arguments go to dynview-eval: `cargo xtask eval --help`
    /// and `cargo xtask eval --real --help` list them.
    #[command(disable_help_flag = true)]
    Eval {
        /// Arguments for dynview-eval (`--real` picks the real captures).
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<OsString>,
    },
    /// Benchmarks (release build): `bench` times frames of the full method on the CPU and the
    /// GPU; `bench sfm` compares our SfM with COLMAP; `bench prep` times the whole prep.
    /// Arguments after the kind go to dynview-eval (`cargo xtask bench sfm --help`).
    #[command(disable_help_flag = true)]
    Bench {
        /// `sfm` or `prep` (none: the renderer), then arguments for dynview-eval.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<OsString>,
    },
    /// The viewer in headless Chromium on the demo event: time to first frame, ms per frame,
    /// wasm package size; `--long-event`: a 2-minute video package instead (first frame, random
    /// scrubs and playback, with the bytes fetched).
    BenchWeb {
        /// Measure a synthetic 2-minute event (made once under target/bench/long-event).
        #[arg(long)]
        long_event: bool,
    },
}

fn main() -> std::process::ExitCode {
    let result = match Cli::parse().command {
        Task::Test => test::run(),
        Task::E2e => test::run_end_to_end(),
        Task::Circles => circles::run().map(|_| ()),
        Task::Demo(args) => demo::run(args),
        Task::Serve(args) => demo::serve_scene(args),
        Task::Eval { args } => {
            let real = args.iter().any(|a| a == "--real");
            let args: Vec<OsString> = args.into_iter().filter(|a| a != "--real").collect();
            setup::ensure_packages(setup::DEMO_PACKAGES).and_then(|()| run_eval(if real { "eval-real" } else { "eval" }, &args, true))
        }
        Task::Bench { args } => match args.first().and_then(|a| a.to_str()) {
            Some("sfm") => setup::ensure_packages(setup::DEMO_PACKAGES)
                .and_then(|()| setup::ensure_packages(setup::BENCH_SFM_PACKAGES))
                .and_then(|()| run_eval("bench-sfm", &args[1..], true)),
            Some("prep") => setup::ensure_packages(setup::DEMO_PACKAGES).and_then(|()| run_eval("bench-prep", &args[1..], true)),
            _ => run_eval("bench", &args, false),
        },
        Task::BenchWeb { long_event } => {
            if long_event {
                bench_web::run_long_event()
            } else {
                bench_web::run()
            }
        }
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// Builds `dynview-eval` (and `dynview` when `with_cli`, which the evaluations run) in release
/// mode and runs `dynview-eval COMMAND ARGS...`.
fn run_eval(command: &str, args: &[OsString], with_cli: bool) -> anyhow::Result<()> {
    let mut build = cargo();
    build.args(["build", "--release", "-p", "dynview-eval"]);
    if with_cli {
        build.args(["-p", "dynview-cli"]);
    }
    run_step("release build of the evaluations", build)?;
    let mut eval = Command::new(workspace_root().join("target/release").join(format!("dynview-eval{}", std::env::consts::EXE_SUFFIX)));
    eval.arg(command).args(args);
    run_step(&format!("dynview-eval {command}"), eval)?;
    Ok(())
}
