//! `cargo xtask demo --real`: the Pose2Sim capture (4 portrait videos, 100 frames) prepared
//! twice, with the Qualisys calibration's poses (`pose2sim-calibrated`) and with our own
//! structure from motion (`pose2sim-sfm`), under `target/demo/`. A preparation that fails is
//! reported and skipped (our SfM finds no initial pair on this wide-baseline capture today);
//! the ones that succeed are served.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::bail;

use crate::pose2sim::{WORKING_WIDTH_PX, videos_dir, write_calibrated_poses};
use crate::prep_runs::{LOG_FILE, run_prep};
use crate::util::{run_step, workspace_root};

/// Prepares both packages (prep skips finished stages; `fresh` starts over) and returns the
/// scenes to serve, by URL name.
pub fn prepare(dynview: &Path, fresh: bool) -> anyhow::Result<Vec<(String, PathBuf)>> {
    let demo = workspace_root().join("target/demo");
    let poses = demo.join("pose2sim-calibration.json");
    write_calibrated_poses(&poses, None)?;
    let width = ["--working-width".to_string(), WORKING_WIDTH_PX.to_string()];
    let calibrated_args = [vec!["--poses".to_string(), poses.display().to_string()], width.to_vec()].concat();
    let runs = [("pose2sim-calibrated", calibrated_args), ("pose2sim-sfm", width.to_vec())];
    let mut scenes = Vec::new();
    let mut failures = Vec::new();
    for (name, args) in runs {
        let out = demo.join(name);
        println!("\n==> {name}: dynview prep on {} (log: {})", videos_dir().display(), out.join(LOG_FILE).display());
        match run_prep(dynview, &videos_dir(), &out, &args, fresh) {
            Ok(run) => {
                let mut info = Command::new(dynview);
                info.arg("info").arg(run.scene_dir());
                run_step(&format!("check the {name} package"), info)?;
                scenes.push((name.to_string(), run.scene_dir()));
            }
            Err(e) => {
                eprintln!("\n!!! {name}: dynview prep failed; going on without it.\n{e:#}\n");
                failures.push(name);
            }
        }
    }
    if scenes.is_empty() {
        bail!("no Pose2Sim package could be prepared ({} failed; see the logs above)", failures.join(", "));
    }
    if !failures.is_empty() {
        println!("\nnot served (prep failed): {}", failures.join(", "));
    }
    Ok(scenes)
}
