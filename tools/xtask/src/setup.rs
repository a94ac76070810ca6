//! Idempotent set-up of a fresh Debian machine: system packages through apt-get (as root; as
//! another user, the exact command to run is printed instead) and Rust targets and components
//! through rustup. Nothing is installed twice.

use std::process::Command;

use anyhow::{Context, bail};

use crate::util::{describe, have, run_step};

/// Debian packages a command needs, with the reason shown to the user.
pub type Packages = &'static [(&'static str, &'static str)];

/// Packages of `cargo xtask demo`.
pub const DEMO_PACKAGES: Packages = &[
    ("ffmpeg", "videos of the sample event; the package's frames as video (VP9)"),
    ("libopencv-dev", "dynview prep: features, matching and geometry (OpenCV 4)"),
    ("clang", "the opencv crate generates its bindings with clang"),
    ("libclang-dev", "the opencv crate generates its bindings with libclang"),
];

/// Packages `cargo xtask bench sfm` needs besides the demo's.
pub const BENCH_SFM_PACKAGES: Packages = &[("colmap", "the reference structure from motion that bench sfm compares with")];

/// Packages of `cargo xtask test`.
pub const TEST_PACKAGES: Packages = &[
    ("ffmpeg", "synthetic event videos; video packages (VP9) written and read in the tests"),
    ("chromium", "headless browser tests of the wasm API and the page"),
    ("chromium-driver", "wasm-bindgen-test-runner drives Chromium through it"),
    ("mesa-vulkan-drivers", "lavapipe: the GPU renderer's tests run on the CPU through Vulkan"),
    ("libopencv-dev", "dynview prep: features, matching and geometry (OpenCV 4)"),
    ("clang", "the opencv crate generates its bindings with clang"),
    ("libclang-dev", "the opencv crate generates its bindings with libclang"),
];

fn is_installed(package: &str) -> bool {
    Command::new("dpkg-query")
        .args(["-W", "-f=${Status}", package])
        .output()
        .is_ok_and(|o| o.status.success() && String::from_utf8_lossy(&o.stdout).contains("install ok installed"))
}

fn is_root() -> bool {
    Command::new("id").arg("-u").output().is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

/// Installs the missing packages of `packages` with apt-get (as root), or stops with the exact
/// command to run.
pub fn ensure_packages(packages: Packages) -> anyhow::Result<()> {
    if !have("dpkg-query") {
        println!("note: not a Debian system; make sure these are installed: {}", names(packages, |_| true).join(" "));
        return Ok(());
    }
    let missing = names(packages, |p| !is_installed(p));
    if missing.is_empty() {
        return Ok(());
    }
    for (p, why) in packages.iter().filter(|(p, _)| missing.contains(&p.to_string())) {
        println!("missing package {p} ({why})");
    }
    let install = format!("apt-get install -y --no-install-recommends {}", missing.join(" "));
    if !is_root() {
        bail!("system packages are missing; run as root:\n    sudo apt-get update && sudo {install}");
    }
    let mut update = Command::new("apt-get");
    update.arg("update");
    run_step("apt-get update", update)?;
    let mut cmd = Command::new("apt-get");
    cmd.args(["install", "-y", "--no-install-recommends"]).args(&missing).env("DEBIAN_FRONTEND", "noninteractive");
    run_step("install system packages", cmd).with_context(|| format!("while running {install}"))?;
    Ok(())
}

fn names(packages: Packages, keep: impl Fn(&str) -> bool) -> Vec<String> {
    packages.iter().map(|(p, _)| p.to_string()).filter(|p| keep(p)).collect()
}

/// Installs Debian's nodejs and npm when `node` or `npm` is missing (a newer Node on PATH is
/// kept).
pub fn ensure_node() -> anyhow::Result<()> {
    if have("node") && have("npm") {
        return Ok(());
    }
    ensure_packages(&[("nodejs", "runs the page's tests"), ("npm", "installs playwright-core for the page's tests")])
}

/// Makes sure rustup has the wasm32 target and the rustfmt and clippy components.
pub fn ensure_rust_tools() -> anyhow::Result<()> {
    if !have("rustup") {
        println!("note: rustup not found; assuming wasm32-unknown-unknown, rustfmt and clippy are installed");
        return Ok(());
    }
    let installed = |args: &[&str], needle: &str| {
        Command::new("rustup").args(args).output().is_ok_and(|o| String::from_utf8_lossy(&o.stdout).lines().any(|l| l.starts_with(needle)))
    };
    if !installed(&["target", "list", "--installed"], "wasm32-unknown-unknown") {
        let mut cmd = Command::new("rustup");
        cmd.args(["target", "add", "wasm32-unknown-unknown"]);
        run_step("add the wasm32 target", cmd)?;
    }
    for component in ["rustfmt", "clippy"] {
        if !installed(&["component", "list", "--installed"], component) {
            let mut cmd = Command::new("rustup");
            cmd.args(["component", "add", component]);
            let label = format!("add {component}");
            run_step(&label, cmd).with_context(|| format!("while running {}", describe(&Command::new("rustup"))))?;
        }
    }
    Ok(())
}
