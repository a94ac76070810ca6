//! `cargo xtask test`: every check and test, after set-up.

use anyhow::bail;

use crate::setup;
use crate::util::{cargo, run_step};

/// Runs the whole test suite.
pub fn run(args: &[String]) -> anyhow::Result<()> {
    if let Some(extra) = args.first() {
        bail!("xtask test takes no arguments, got {extra:?}");
    }
    setup::ensure_packages(setup::TEST_PACKAGES)?;
    setup::ensure_rust_tools()?;
    let mut timings = Vec::new();

    let mut fmt = cargo();
    fmt.args(["fmt", "--all", "--check"]);
    timings.push(("cargo fmt --check", run_step("formatting", fmt)?));

    let mut clippy = cargo();
    clippy.args(["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"]);
    timings.push(("clippy", run_step("clippy, warnings denied", clippy)?));

    let mut tests = cargo();
    tests.args(["test", "--workspace"]);
    timings.push(("native tests", run_step("native tests", tests)?));

    let mut wasm = cargo();
    wasm.args(["build", "-p", "dynview-core", "--no-default-features", "--target", "wasm32-unknown-unknown"]);
    timings.push(("wasm32 build of dynview-core", run_step("wasm32 build of the core", wasm)?));

    println!("\nall checks passed:");
    for (name, secs) in timings {
        println!("  {name:<32} {secs:>7.1} s");
    }
    Ok(())
}
