//! `cargo xtask bench-web`: the viewer measured in headless Chromium on the demo event (time to
//! first frame, CPU-path ms per frame at 480x270 and 960x540) and the wasm package size.

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
