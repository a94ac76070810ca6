//! `cargo xtask demo`: install what is missing, build, make the sample event, serve the viewer.

use std::process::Command;

use anyhow::{Context, bail};

use crate::serve::{self, Site};
use crate::setup;
use crate::util::{cargo, run_step, workspace_root};
use crate::web;

/// Port the demo listens on first (the next free one is taken when it is busy).
const DEMO_PORT: u16 = 8080;

/// Builds the CLI, generates the sample event (unless present), builds the wasm package and
/// serves the page with the event until Ctrl-C.
pub fn run(args: &[String]) -> anyhow::Result<()> {
    let mut fresh = false;
    let mut serve = true;
    let mut port = DEMO_PORT;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--fresh" => fresh = true,
            "--no-serve" => serve = false,
            "--port" => port = it.next().context("--port needs a number")?.parse().context("--port needs a number")?,
            other => bail!("unknown option {other:?} for xtask demo (known: --fresh, --no-serve, --port N)"),
        }
    }
    setup::ensure_packages(setup::DEMO_PACKAGES)?;
    setup::ensure_rust_tools()?;
    let event = make_sample_event(fresh)?;
    let size = web::build_package()?;
    println!("    wasm package: {:.2} MB", size as f64 / 1e6);
    if !serve {
        return Ok(());
    }
    let site = Site { web_dir: web::web_dir(), scenes: vec![("demo".into(), event.join("scene"))] };
    serve::serve_forever(&site, port, |addr| {
        println!("\n==> dynview viewer with the sample event:\n\n    http://{addr}/?scene=scenes/demo/\n\n    (Ctrl-C stops the server)");
    })
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
    if fresh || !event.join("synth.json").is_file() {
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
