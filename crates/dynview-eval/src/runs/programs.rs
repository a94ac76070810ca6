//! Running the programs the evaluations measure: the `dynview` binary they call, and commands
//! run with their output in a log, timed, whose failures quote the log's end.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::Instant;

use anyhow::{Context, bail};

use crate::paths::command_line as describe;

/// Lines of a failed step's log shown in the error.
const LOG_TAIL_LINES: usize = 15;

/// Runs `cmd` with its output in `log` (appended); returns the wall seconds and the status.
pub fn run_logged_status(label: &str, mut cmd: Command, log: &Path) -> anyhow::Result<(f64, ExitStatus)> {
    println!("    {label}: {}", describe(&cmd));
    let file = std::fs::OpenOptions::new().create(true).append(true).open(log).with_context(|| format!("cannot open {}", log.display()))?;
    cmd.stdin(Stdio::null()).stdout(file.try_clone()?).stderr(file);
    let start = Instant::now();
    let status = cmd.status().with_context(|| format!("cannot start {}", describe(&cmd)))?;
    let secs = start.elapsed().as_secs_f64();
    println!("      {} in {secs:.1} s", if status.success() { "ok" } else { "failed" });
    Ok((secs, status))
}

/// The last lines of `log`.
pub fn log_tail(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(LOG_TAIL_LINES)..].join("\n")
}

/// [`run_logged_status`], failing when the command fails; the error quotes the log's tail.
pub fn run_logged(label: &str, cmd: Command, log: &Path) -> anyhow::Result<f64> {
    let (secs, status) = run_logged_status(label, cmd, log)?;
    if !status.success() {
        bail!("{label} failed ({status}) after {secs:.1} s; the end of {}:\n{}", log.display(), log_tail(log));
    }
    Ok(secs)
}

/// The `dynview` binary: `$DYNVIEW_BIN` when set, else `dynview` beside this program (`cargo
/// xtask eval` and `bench` build both into `target/release/`).
pub fn dynview_binary() -> anyhow::Result<PathBuf> {
    let path = match std::env::var_os("DYNVIEW_BIN") {
        Some(path) => PathBuf::from(path),
        None => {
            let exe = std::env::current_exe().context("cannot locate this program")?;
            exe.with_file_name(format!("dynview{}", std::env::consts::EXE_SUFFIX))
        }
    };
    if !path.is_file() {
        bail!("no dynview binary at {} (build it with `cargo build --release -p dynview-cli`, or set DYNVIEW_BIN)", path.display());
    }
    Ok(path)
}
