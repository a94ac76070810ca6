//! `cargo xtask bench-web`: the viewer measured in headless Chromium on the demo event (time to
//! first frame, CPU-path ms per frame at 480x270 and 960x540) and the wasm package size;
//! `--long-event`: on a synthetic 2-minute event stored as video (format v2).

use std::process::Command;

use anyhow::Context;

use crate::demo::make_sample_event;
use crate::serve::{self, Site};
use crate::util::run_step;
use crate::{setup, web};

/// Builds everything, serves the demo event on a free port and runs `web/tests/bench/measure.mjs`.
pub fn run() -> anyhow::Result<()> {
    setup::ensure_packages(setup::TEST_PACKAGES)?;
    setup::ensure_node()?;
    setup::ensure_rust_tools()?;
    web::ensure_npm_packages()?;
    let event = make_sample_event(false)?;
    let wasm_bytes = web::build_package()?;
    let wasm = web::web_dir().join("pkg/dynview_web_bg.wasm");
    let gzip = Command::new("gzip").args(["-9", "-c"]).arg(&wasm).output().context("gzip is needed to measure the package")?;
    let js_bytes = std::fs::metadata(web::web_dir().join("pkg/dynview_web.js"))?.len();
    let site = Site { web_dir: web::web_dir(), scenes: vec![("demo".into(), event.join("scene"))] };
    let server = serve::start(&site, 0)?;
    let mut measure = Command::new("node");
    measure.current_dir(web::web_dir()).arg("tests/bench/measure.mjs").env("DYNVIEW_BASE_URL", format!("http://{}/", server.addr));
    run_step("measure the viewer in headless Chromium (CPU path)", measure)?;
    println!(
        "\nwasm package: dynview_web_bg.wasm {:.0} KiB ({:.0} KiB gzip -9), dynview_web.js {:.0} KiB",
        wasm_bytes as f64 / 1024.0,
        gzip.stdout.len() as f64 / 1024.0,
        js_bytes as f64 / 1024.0
    );
    Ok(())
}

/// The long event: `dynview synth` defaults (6 cameras, 960x540) for 2 minutes at 10 fps.
const LONG_EVENT_FRAMES: u32 = 1200;
const LONG_EVENT_FPS: u32 = 10;

/// Makes (once) the 2-minute synthetic event and its video package under
/// `target/bench/long-event`, serves it and runs `web/tests/bench/long_event.mjs`.
pub fn run_long_event() -> anyhow::Result<()> {
    setup::ensure_packages(setup::TEST_PACKAGES)?;
    setup::ensure_node()?;
    setup::ensure_rust_tools()?;
    web::ensure_npm_packages()?;
    let dynview = crate::demo::dynview_release()?;
    let root = crate::util::workspace_root().join("target/bench/long-event");
    let event = root.join("event");
    let video = root.join("video");
    if !video.join("scene.json").is_file() {
        if !event.join("scene").join("scene.json").is_file() {
            let mut synth = Command::new(&dynview);
            synth.arg("synth").arg("--out").arg(&event).arg("--no-video");
            synth.args(["--frames", &LONG_EVENT_FRAMES.to_string(), "--fps", &LONG_EVENT_FPS.to_string()]);
            run_step("make the 2-minute event (once; tens of minutes)", synth)?;
        }
        let mut repack = Command::new(&dynview);
        repack.arg("repack").arg(event.join("scene")).arg("--out").arg(&video);
        run_step("store its frames as video (format v2)", repack)?;
    }
    web::build_package()?;
    let site = Site { web_dir: web::web_dir(), scenes: vec![("long".into(), video)] };
    let server = serve::start(&site, 0)?;
    let mut measure = Command::new("node");
    measure.current_dir(web::web_dir()).arg("tests/bench/long_event.mjs").env("DYNVIEW_BASE_URL", format!("http://{}/", server.addr));
    run_step("measure the viewer on the 2-minute event in headless Chromium (CPU path)", measure)?;
    Ok(())
}
