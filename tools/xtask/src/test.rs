//! `cargo xtask test`: every check and test, after set-up: formatting, clippy (native and
//! wasm32), native tests, the wasm API's tests in headless Chromium, the page's unit tests and
//! its end-to-end tests in headless Chromium against the real server.

use std::process::Command;

use crate::fixtures::{BrowserFixture, browser_fixture};
use crate::serve::{self, Site};
use crate::util::{cargo, run_step, workspace_root};
use crate::{circles, setup, web};

/// Size of the browser-test event: small enough for a fast CI, large enough to be a real scene.
const FIXTURE: (u32, u32, u32) = (4, 320, 180);

/// Runs the whole test suite.
pub fn run() -> anyhow::Result<()> {
    setup::ensure_packages(setup::TEST_PACKAGES)?;
    setup::ensure_node()?;
    setup::ensure_rust_tools()?;
    web::ensure_wasm_bindgen()?;
    web::ensure_wasm_pack()?;
    web::ensure_npm_packages()?;
    let mut timings = Vec::new();

    let mut fmt = cargo();
    fmt.args(["fmt", "--all", "--check"]);
    timings.push(("cargo fmt --check", run_step("formatting", fmt)?));

    let mut clippy = cargo();
    clippy.args(["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"]);
    timings.push(("clippy", run_step("clippy, warnings denied", clippy)?));

    timings.push(("dependency rules", dependency_rules()?));
    timings.push(("no import circles", circles::run()?));

    let mut tests = cargo();
    tests.args(["test", "--workspace"]);
    timings.push(("native tests", run_step("native tests", tests)?));

    let mut wasm = cargo();
    wasm.args(["build", "-p", "dynview-core", "--no-default-features", "-p", "dynview-camera", "-p", "dynview-interchange"]);
    wasm.args(["--target", "wasm32-unknown-unknown"]);
    timings.push((
        "wasm32 build of the pure crates",
        run_step("wasm32 build of the core, the camera models and the interchange formats", wasm)?,
    ));

    let mut wasm_gpu = cargo();
    wasm_gpu.args(["clippy", "-p", "dynview-gpu", "--lib", "--target", "wasm32-unknown-unknown", "--", "-D", "warnings"]);
    timings.push(("wasm32 clippy of dynview-gpu", run_step("the GPU renderer builds for the browser (wasm32, WebGPU)", wasm_gpu)?));

    let fixture = fixture()?;

    let mut clippy_wasm = cargo();
    clippy_wasm.args(["clippy", "-p", "dynview-web", "--all-targets", "--target", "wasm32-unknown-unknown", "--", "-D", "warnings"]);
    timings.push(("clippy (wasm32)", run_step("clippy of the wasm crate and its tests for wasm32", clippy_wasm)?));

    let chromedriver = which("chromedriver").unwrap_or_else(|| "/usr/bin/chromedriver".into());
    let wasm_tests = web::wasm_pack_test(&chromedriver);
    timings.push(("wasm API tests (Chromium)", run_step("wasm API tests in headless Chromium (wasm-pack test)", wasm_tests)?));

    let mut unit = Command::new("node");
    unit.current_dir(web::web_dir()).args(["--test", "tests/unit/"]);
    timings.push(("page unit tests (node)", run_step("the page's unit tests", unit)?));

    timings.push(("end-to-end tests (Playwright)", end_to_end(&fixture)?));

    println!("\nall checks passed:");
    for (name, secs) in timings {
        println!("  {name:<32} {secs:>7.1} s");
    }
    Ok(())
}

/// The full path of `program` on PATH.
fn which(program: &str) -> Option<String> {
    let out = Command::new("sh").arg("-c").arg(format!("command -v {program}")).output().ok()?;
    let path = String::from_utf8_lossy(&out.stdout).trim().to_owned();
    (out.status.success() && !path.is_empty()).then_some(path)
}

/// Builds the debug CLI (same features as the workspace tests, so nothing is rebuilt) and
/// makes the browser-test fixture with it.
fn fixture() -> anyhow::Result<BrowserFixture> {
    let root = workspace_root();
    let mut build_cli = cargo();
    build_cli.args(["build", "--workspace", "--bins"]);
    run_step("build dynview (debug) for the fixtures", build_cli)?;
    let (frames, width, height) = FIXTURE;
    browser_fixture(&root.join("target/debug/dynview"), &root.join("target/browser-fixture"), frames, width, height)
}

/// `cargo xtask e2e`: only the end-to-end tests of the page (fixture, wasm package, server,
/// Playwright).
pub fn run_end_to_end() -> anyhow::Result<()> {
    setup::ensure_packages(setup::TEST_PACKAGES)?;
    setup::ensure_node()?;
    web::ensure_npm_packages()?;
    end_to_end(&fixture()?)?;
    Ok(())
}

/// Builds the wasm package, serves the page with the fixture scenes on a free port and runs
/// the Playwright tests; returns their duration.
fn end_to_end(fixture: &BrowserFixture) -> anyhow::Result<f64> {
    let root = workspace_root();
    web::build_package()?;
    let site = Site {
        web_dir: web::web_dir(),
        scenes: vec![
            ("e2e".into(), fixture.event.join("scene")),
            ("corrupt".into(), fixture.corrupt_scene.clone()),
            ("video".into(), fixture.video_scene.clone()),
            ("phones".into(), fixture.phones.join("prep/scene")),
        ],
    };
    let server = serve::start(&site, 0)?;
    let out = root.join("target/e2e");
    std::fs::create_dir_all(&out)?;
    let mut e2e = Command::new("node");
    e2e.current_dir(web::web_dir())
        .args(["--test", "--test-concurrency=1", "tests/e2e/"])
        .env("DYNVIEW_BASE_URL", format!("http://{}/", server.addr))
        .env("DYNVIEW_BIN", root.join("target/debug/dynview"))
        .env("DYNVIEW_E2E_OUT", &out)
        .env("DYNVIEW_E2E_SCENE", fixture.event.join("scene"))
        .env("DYNVIEW_E2E_VIDEO_SCENE", &fixture.video_scene)
        .env("DYNVIEW_E2E_PHONES", &fixture.phones)
        .env("CHROMIUM", which("chromium").unwrap_or_else(|| "/usr/bin/chromium".into()));
    let secs = run_step("end-to-end tests of the page in headless Chromium", e2e)?;
    drop(server);
    println!("    screenshots: {}", out.display());
    Ok(secs)
}

/// Crates (with cargo's feature flags) that must not link a dependency, and which.
const FORBIDDEN_DEPENDENCIES: &[(&str, &[&str], &str)] = &[
    ("dynview-core", &[], "opencv"),
    ("dynview-interchange", &[], "opencv"),
    ("dynview-gpu", &[], "opencv"),
    ("dynview-web", &[], "opencv"),
    ("dynview-eval", &[], "opencv"),
    ("dynview-cli", &["--no-default-features"], "opencv"),
    ("dynview-core", &[], "wgpu"),
    ("xtask", &[], "wgpu"),
];

/// Checks the workspace's dependency rules (docs/ARCHITECTURE.md): OpenCV only through
/// dynview-sfm and the CLI's `prep` feature, no GPU in the core or xtask, and that the CLI
/// builds without OpenCV.
fn dependency_rules() -> anyhow::Result<f64> {
    println!("\n==> dependency rules (docs/ARCHITECTURE.md)");
    let start = std::time::Instant::now();
    for (krate, flags, forbidden) in FORBIDDEN_DEPENDENCIES {
        let out = cargo()
            .args(["tree", "-p", krate, "-e", "normal,build", "--prefix", "none", "--format", "{p}"])
            .args(*flags)
            .output()
            .map_err(|e| anyhow::anyhow!("cannot run cargo tree: {e}"))?;
        if !out.status.success() {
            anyhow::bail!("cargo tree -p {krate} failed: {}", String::from_utf8_lossy(&out.stderr));
        }
        let tree = String::from_utf8_lossy(&out.stdout);
        if let Some(line) = tree.lines().find(|l| l.split_whitespace().next() == Some(forbidden)) {
            anyhow::bail!("{krate} {} depends on {forbidden} ({line}); see docs/ARCHITECTURE.md", flags.join(" "));
        }
        println!("    {krate} {}: no {forbidden}", flags.join(" "));
    }
    let mut build = cargo();
    build.args(["build", "-p", "dynview-cli", "--no-default-features"]);
    let secs = run_step("dynview without OpenCV (dynview-cli --no-default-features)", build)?;
    Ok(start.elapsed().as_secs_f64().max(secs))
}
