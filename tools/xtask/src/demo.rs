//! `cargo xtask demo`: build, make the sample event, show it.

use std::process::Command;

use anyhow::bail;

use crate::setup;
use crate::util::{cargo, run_step, workspace_root};

/// Builds the CLI, generates the sample event (unless present) and prints its package summary.
pub fn run(args: &[String]) -> anyhow::Result<()> {
    let mut fresh = false;
    for a in args {
        match a.as_str() {
            "--fresh" => fresh = true,
            other => bail!("unknown option {other:?} for xtask demo (known: --fresh)"),
        }
    }
    setup::ensure_packages(setup::DEMO_PACKAGES)?;
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
    Ok(())
}
