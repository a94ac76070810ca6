//! Running `dynview prep` for the demos (`demo` on the sample event, `demo_real` on the real
//! captures): one prep run, reported as a step.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::Context;

use crate::util::run_step;

/// Runs `dynview prep --input INPUT --out OUT EXTRA...` (with `fresh`, `OUT` is removed first;
/// otherwise prep itself skips the stages an earlier run finished) and returns the package
/// folder it wrote.
pub fn run_prep(dynview: &Path, input: &Path, out: &Path, extra: &[String], fresh: bool, label: &str) -> anyhow::Result<PathBuf> {
    if fresh && out.exists() {
        std::fs::remove_dir_all(out).with_context(|| format!("cannot remove {}", out.display()))?;
    }
    let mut prep = Command::new(dynview);
    prep.arg("prep").arg("--input").arg(input).arg("--out").arg(out).args(extra);
    run_step(label, prep)?;
    Ok(out.join("scene"))
}
