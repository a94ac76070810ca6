//! `cargo xtask demo`: install what is missing, build, make the sample event, run `dynview prep`
//! on its videos and serve the viewer with the result (and the event's ground-truth package
//! beside it). `--real` prepares and serves the Pose2Sim capture instead (see `demo_real`).

use std::path::PathBuf;
use std::process::Command;

use anyhow::{Context, bail};

use crate::prep_runs::run_prep;
use crate::serve::{self, Site};
use crate::setup;
use crate::util::{cargo, run_step, workspace_root};
use crate::web;

/// Port the demo listens on first (the next free one is taken when it is busy).
const DEMO_PORT: u16 = 8080;

/// Builds the CLI, makes the sample event (unless present), prepares it from its videos, builds
/// the wasm package and serves the page until Ctrl-C.
pub fn run(args: &[String]) -> anyhow::Result<()> {
    let mut fresh = false;
    let mut serve = true;
    let mut real = false;
    let mut port = DEMO_PORT;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--fresh" => fresh = true,
            "--no-serve" => serve = false,
            "--real" => real = true,
            "--port" => port = it.next().context("--port needs a number")?.parse().context("--port needs a number")?,
            other => bail!("unknown option {other:?} for xtask demo (known: --fresh, --real, --no-serve, --port N)"),
        }
    }
    setup::ensure_packages(setup::DEMO_PACKAGES)?;
    setup::ensure_rust_tools()?;
    let scenes = if real {
        crate::demo_real::prepare(&dynview_release()?, fresh)?
    } else {
        let event = make_sample_event(fresh)?;
        let prepared = prepare_sample_event(&event, fresh)?;
        vec![("demo".to_string(), prepared), ("demo-truth".to_string(), event.join("scene"))]
    };
    let size = web::build_package()?;
    println!("    wasm package: {:.2} MB", size as f64 / 1e6);
    if !serve {
        return Ok(());
    }
    let site = Site { web_dir: web::web_dir(), scenes: scenes.clone() };
    serve::serve_forever(&site, port, |addr| {
        println!("\n==> dynview viewer:\n");
        for (name, dir) in &scenes {
            println!("    http://{addr}/?scene=scenes/{name}/\n        ({})", dir.display());
        }
        println!("\n    (Ctrl-C stops the server)");
    })
}

/// The release `dynview` binary (built by [`make_sample_event`] or here).
fn dynview_release() -> anyhow::Result<PathBuf> {
    let mut build = cargo();
    build.args(["build", "--release", "-p", "dynview-cli"]);
    run_step("build dynview (release)", build)?;
    Ok(workspace_root().join("target/release").join(format!("dynview{}", std::env::consts::EXE_SUFFIX)))
}

/// Runs `dynview prep` on the sample event's videos into `target/demo/prep` (prep skips the
/// stages a former run finished; `fresh` starts over) and checks the package with
/// `dynview info`; returns the package folder.
fn prepare_sample_event(event: &std::path::Path, fresh: bool) -> anyhow::Result<PathBuf> {
    let dynview = workspace_root().join("target/release").join(format!("dynview{}", std::env::consts::EXE_SUFFIX));
    let videos = event.join("videos");
    if !videos.is_dir() {
        bail!("{} is missing (ffmpeg was not installed when the event was made?); run `cargo xtask demo --fresh`", videos.display());
    }
    let out = workspace_root().join("target/demo/prep");
    println!("\n==> dynview prep on the sample event's videos (log: {})", out.join(crate::prep_runs::LOG_FILE).display());
    let run = run_prep(&dynview, &videos, &out, &[], fresh)?;
    let mut info = Command::new(&dynview);
    info.arg("info").arg(run.scene_dir());
    run_step("check the prepared scene package", info)?;
    Ok(run.scene_dir())
}

/// Builds the release CLI and makes the sample event under `target/demo/event` unless it is
/// there already (or `fresh`); returns the event folder.
pub fn make_sample_event(fresh: bool) -> anyhow::Result<std::path::PathBuf> {
    let mut build = cargo();
    build.args(["build", "--release", "-p", "dynview-cli"]);
    run_step("build dynview (release)", build)?;

    let root = workspace_root();
    let dynview = root.join("target/release/dynview");
    let event = root.join("target/demo/event");
    // An event made before ffmpeg was installed has no videos for prep: make it again.
    if fresh || !event.join("synth.json").is_file() || !event.join("videos").is_dir() {
        let mut synth = Command::new(&dynview);
        synth.arg("synth").arg("--out").arg(&event);
        run_step("make the sample event", synth)?;
    } else {
        println!("\n==> sample event already at {} (use --fresh to remake it)", event.display());
    }
    let mut info = Command::new(&dynview);
    info.arg("info").arg(event.join("scene"));
    run_step("check the sample event's scene package", info)?;
    Ok(event)
}

/// `cargo xtask serve SCENE [--port N]`: builds the wasm package and serves the viewer with
/// the scene package folder `SCENE` at `/scenes/scene/`.
pub fn serve_scene(args: &[String]) -> anyhow::Result<()> {
    let mut scene = None;
    let mut port = DEMO_PORT;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--port" => port = it.next().context("--port needs a number")?.parse().context("--port needs a number")?,
            other if scene.is_none() && !other.starts_with('-') => scene = Some(std::path::PathBuf::from(other)),
            other => bail!("unknown option {other:?} for xtask serve (usage: serve SCENE [--port N])"),
        }
    }
    let scene = scene.context("usage: cargo xtask serve SCENE [--port N]")?;
    setup::ensure_rust_tools()?;
    web::build_package()?;
    let site = Site { web_dir: web::web_dir(), scenes: vec![("scene".into(), scene)] };
    serve::serve_forever(&site, port, |addr| println!("\n==> http://{addr}/?scene=scenes/scene/  (Ctrl-C stops)"))
}
