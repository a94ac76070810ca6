//! Running commands with clear reporting.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, bail};

/// The workspace root (the parent of `tools/`).
pub fn workspace_root() -> PathBuf {
    let manifest_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest_dir.ancestors().nth(2).map(PathBuf::from).unwrap_or(manifest_dir)
}

/// The cargo that runs this xtask.
pub fn cargo() -> Command {
    let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cmd.current_dir(workspace_root());
    cmd
}

/// Runs `cmd`, printing it first and its duration after; fails when it fails.
pub fn run_step(label: &str, mut cmd: Command) -> anyhow::Result<f64> {
    println!("\n==> {label}\n    $ {}", describe(&cmd));
    let start = Instant::now();
    let status = cmd.status().with_context(|| format!("cannot start {}", describe(&cmd)))?;
    let secs = start.elapsed().as_secs_f64();
    if !status.success() {
        bail!("{label} failed ({status}) after {secs:.1} s");
    }
    println!("    ok in {secs:.1} s");
    Ok(secs)
}

/// The command line of `cmd` as text.
pub fn describe(cmd: &Command) -> String {
    let mut s = cmd.get_program().to_string_lossy().into_owned();
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}

/// True when `program` can be started (found on PATH).
pub fn have(program: &str) -> bool {
    Command::new(program).arg("--version").output().is_ok()
}
