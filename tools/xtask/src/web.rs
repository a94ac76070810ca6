//! Building the viewer: the wasm package (cargo + wasm-bindgen, no tool that downloads
//! binaries at run time) into `web/pkg/`, and the page's npm test dependencies.

use std::path::PathBuf;
use std::process::Command;

use anyhow::{Context, bail};

use crate::util::{cargo, have, run_step, workspace_root};

/// The wasm-bindgen version pinned in `crates/dynview-web/Cargo.toml`; the CLI must match it.
pub const WASM_BINDGEN_VERSION: &str = "0.2.130";

/// The wasm-bindgen CLI's version, when installed.
fn wasm_bindgen_version() -> Option<String> {
    let out = Command::new("wasm-bindgen").arg("--version").output().ok()?;
    String::from_utf8_lossy(&out.stdout).split_whitespace().nth(1).map(str::to_owned)
}

/// Installs wasm-bindgen-cli (with `wasm-bindgen-test-runner`) unless the pinned version is
/// already on PATH.
pub fn ensure_wasm_bindgen() -> anyhow::Result<()> {
    match wasm_bindgen_version() {
        Some(v) if v == WASM_BINDGEN_VERSION => return Ok(()),
        Some(v) => println!("wasm-bindgen {v} found, {WASM_BINDGEN_VERSION} needed"),
        None => println!("wasm-bindgen not found"),
    }
    let mut install = cargo();
    install.args(["install", "wasm-bindgen-cli", "--version", WASM_BINDGEN_VERSION]);
    run_step("install wasm-bindgen-cli (a few minutes, once)", install)?;
    Ok(())
}

/// The wasm-pack version `cargo xtask test` installs (from crates.io) to run the wasm API's
/// browser tests as users of wasm crates do.
pub const WASM_PACK_VERSION: &str = "0.15.1";

/// The version of the `wasm-pack` on PATH, if any.
fn wasm_pack_version() -> Option<String> {
    let out = Command::new("wasm-pack").arg("--version").output().ok()?;
    String::from_utf8_lossy(&out.stdout).split_whitespace().nth(1).map(str::to_owned)
}

/// Installs wasm-pack from crates.io unless the pinned version is already on PATH. It finds
/// the installed wasm-bindgen-test-runner (same version as the pinned wasm-bindgen) and
/// chromedriver on PATH and downloads nothing; [`wasm_pack_test`] runs it with `--mode
/// no-install` so that it fails rather than downloads.
pub fn ensure_wasm_pack() -> anyhow::Result<()> {
    match wasm_pack_version() {
        Some(v) if v == WASM_PACK_VERSION => return Ok(()),
        Some(v) => println!("wasm-pack {v} found, {WASM_PACK_VERSION} wanted"),
        None => println!("wasm-pack not found"),
    }
    let mut install = cargo();
    install.args(["install", "wasm-pack", "--version", WASM_PACK_VERSION]);
    run_step("install wasm-pack (a few minutes, once)", install)?;
    Ok(())
}

/// `wasm-pack test --headless --chrome crates/dynview-web`: the wasm API's tests in headless
/// Chromium (flags in `crates/dynview-web/webdriver.json`), driven by `chromedriver`, with no
/// downloads. Returns the command to run.
pub fn wasm_pack_test(chromedriver: &str) -> Command {
    let mut test = Command::new("wasm-pack");
    test.current_dir(workspace_root());
    test.args(["test", "--headless", "--chrome", "--mode", "no-install", "--chromedriver", chromedriver]);
    test.arg("crates/dynview-web");
    test
}

/// The folder of the page.
pub fn web_dir() -> PathBuf {
    workspace_root().join("web")
}

/// Builds `dynview-web` for wasm32 (profile `wasm-release`) and generates the JS bindings
/// into `web/pkg/`. Returns the size of the `.wasm` in bytes.
pub fn build_package() -> anyhow::Result<u64> {
    ensure_wasm_bindgen()?;
    let mut build = cargo();
    build.args(["build", "-p", "dynview-web", "--target", "wasm32-unknown-unknown", "--profile", "wasm-release"]);
    run_step("build the viewer's wasm (wasm-release)", build)?;
    let wasm = workspace_root().join("target/wasm32-unknown-unknown/wasm-release/dynview_web.wasm");
    let out = web_dir().join("pkg");
    let mut bindgen = Command::new("wasm-bindgen");
    bindgen.args(["--target", "web", "--no-typescript", "--out-dir"]).arg(&out).arg(&wasm);
    run_step("generate the JS bindings into web/pkg", bindgen)?;
    let size = std::fs::metadata(out.join("dynview_web_bg.wasm")).context("wasm-bindgen wrote no dynview_web_bg.wasm")?.len();
    Ok(size)
}

/// Installs the page's npm test dependencies (playwright-core, pngjs) from the lock file
/// unless `web/node_modules` is current. No browser is downloaded: tests drive Debian's
/// Chromium.
pub fn ensure_npm_packages() -> anyhow::Result<()> {
    if !have("npm") || !have("node") {
        bail!("node and npm are needed for the browser tests; run as root:\n    apt-get install -y nodejs npm");
    }
    let dir = web_dir();
    let lock = dir.join("package-lock.json");
    let stamp = dir.join("node_modules/.package-lock.json");
    let fresh = |p: &PathBuf| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    if fresh(&stamp).is_some() && fresh(&stamp) >= fresh(&lock) {
        return Ok(());
    }
    let mut ci = Command::new("npm");
    ci.current_dir(&dir).args(["ci", "--no-audit", "--no-fund"]).env("PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD", "1");
    run_step("install the page's npm test packages", ci)?;
    Ok(())
}
