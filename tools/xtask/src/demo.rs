//! `cargo xtask demo`: install what is missing, build, make the sample event, run `dynview prep`
//! on its videos and serve the viewer with the result (and the event's ground-truth package
//! beside it). `--real` prepares and serves the real captures instead (see `demo_real`).

use std::path::PathBuf;
use std::process::Command;

use anyhow::bail;

use crate::dynview_prep::run_prep;
use crate::serve::{self, Site};
use crate::setup;
use crate::util::{cargo, run_step, workspace_root};
use crate::web;

/// Port the demo listens on first (the next free one is taken when it is busy).
const DEMO_PORT: u16 = 8080;

/// Options of `cargo xtask demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Remake the sample event and redo prep.
    #[arg(long)]
    pub fresh: bool,
    /// The real captures instead (Panoptic's two arcs, Pose2Sim), each prepared with its
    /// calibration and with our SfM.
    #[arg(long)]
    pub real: bool,
    /// Port to listen on first (the next free one is taken when it is busy).
    #[arg(long, default_value_t = DEMO_PORT)]
    pub port: u16,
    /// Build and prepare, then stop without serving.
    #[arg(long)]
    pub no_serve: bool,
}

/// Builds the CLI, makes the sample event (unless present), prepares it from its videos, builds
/// the wasm package and serves the page until Ctrl-C.
pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    let DemoArgs { fresh, real, port, no_serve } = args;
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
    if no_serve {
        return Ok(());
    }
    let site = Site { web_dir: web::web_dir(), scenes: scenes.clone() };
    serve::serve_forever(&site, port, |addr| {
        println!("\n==> dynview viewer:\n");
        for (name, dir) in &scenes {
            println!("    http://{addr}/?scene=scenes/{name}/\n        ({})", dir.display());
        }
        if scenes.iter().any(|(name, _)| name == "demo") {
            println!("    http://{addr}/embed.html\n        (a page that embeds the demo scene with <dynview-viewer>)");
        }
        println!("\n    (Ctrl-C stops the server)");
    })
}

/// The release `dynview` binary (built by [`make_sample_event`] or here).
pub fn dynview_release() -> anyhow::Result<PathBuf> {
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
    let scene = run_prep(&dynview, &videos, &out, &[], fresh, "dynview prep on the sample event's videos")?;
    let mut info = Command::new(&dynview);
    info.arg("info").arg(&scene);
    run_step("check the prepared scene package", info)?;
    Ok(scene)
}

/// Builds the release CLI and makes the sample event under `target/demo/event` unless it is
/// there already (or `fresh`); returns the event folder.
pub fn make_sample_event(fresh: bool) -> anyhow::Result<std::path::PathBuf> {
    let dynview = dynview_release()?;
    let root = workspace_root();
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

/// Options of `cargo xtask serve`.
#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// The scene package folder to open.
    pub scene: PathBuf,
    /// Port to listen on first (the next free one is taken when it is busy).
    #[arg(long, default_value_t = DEMO_PORT)]
    pub port: u16,
}

/// `cargo xtask serve SCENE`: builds the wasm package and serves the viewer with one scene.
pub fn serve_scene(args: ServeArgs) -> anyhow::Result<()> {
    setup::ensure_rust_tools()?;
    web::build_package()?;
    let site = Site { web_dir: web::web_dir(), scenes: vec![("scene".into(), args.scene)] };
    serve::serve_forever(&site, args.port, |addr| println!("\n==> http://{addr}/?scene=scenes/scene/  (Ctrl-C stops)"))
}
