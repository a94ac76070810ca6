//! Where the evaluations find their data and put their results, and how they name commands.

use std::path::PathBuf;
use std::process::Command;

/// The workspace root: `$DYNVIEW_ROOT` when set (a binary copied to another machine), else
/// the checkout this crate was built in.
pub fn workspace_root() -> PathBuf {
    if let Some(root) = std::env::var_os("DYNVIEW_ROOT") {
        return PathBuf::from(root);
    }
    let manifest_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest_dir.ancestors().nth(2).map(PathBuf::from).unwrap_or(manifest_dir)
}

/// `docs/results/`, where the committed result tables and strips live.
pub fn results_dir() -> PathBuf {
    workspace_root().join("docs/results")
}

/// The shared data folder (`../shared/data` beside the checkout).
pub fn shared_data() -> PathBuf {
    workspace_root().join("../shared/data")
}

/// A command line as text, for messages.
pub fn command_line(cmd: &Command) -> String {
    format!("{cmd:?}")
}
