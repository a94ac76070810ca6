//! `cargo xtask demo --real`: the Pose2Sim capture (4 portrait videos, 100 frames) prepared
//! twice, with the Qualisys calibration's poses (`pose2sim-calibrated`) and with our own
//! structure from motion (`pose2sim-sfm`), under `target/demo/`. A preparation that fails is
//! reported and skipped (our SfM finds no initial pair on this wide-baseline capture today);
//! the ones that succeed are served.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::bail;

use crate::dynview_prep::run_prep;
use crate::util::{run_step, workspace_root};

/// Working width of prep's frames for the portrait 1088x1920 videos (540x953 frames).
const WORKING_WIDTH_PX: u32 = 540;

/// The capture's folder in the shared data beside the checkout.
fn source_dir() -> PathBuf {
    workspace_root().join("../shared/data/pose2sim-multiperson")
}

/// Prepares both packages (prep skips finished stages; `fresh` starts over) and returns the
/// scenes to serve, by URL name.
pub fn prepare(dynview: &Path, fresh: bool) -> anyhow::Result<Vec<(String, PathBuf)>> {
    let demo = workspace_root().join("target/demo");
    let poses = demo.join("pose2sim-calibration.json");
    let mut import = Command::new(dynview);
    import.arg("import").arg(source_dir().join("calibration/Calib.qca.txt")).arg("--out").arg(&poses);
    run_step("the Qualisys calibration as poses.json (dynview import)", import)?;
    let videos = source_dir().join("videos");
    let width = ["--working-width".to_string(), WORKING_WIDTH_PX.to_string()];
    let calibrated_args = [vec!["--poses".to_string(), poses.display().to_string()], width.to_vec()].concat();
    let runs = [("pose2sim-calibrated", calibrated_args), ("pose2sim-sfm", width.to_vec())];
    let mut scenes = Vec::new();
    let mut failures = Vec::new();
    for (name, args) in runs {
        let out = demo.join(name);
        match run_prep(dynview, &videos, &out, &args, fresh, &format!("{name}: dynview prep on {}", videos.display())) {
            Ok(scene) => {
                let mut info = Command::new(dynview);
                info.arg("info").arg(&scene);
                run_step(&format!("check the {name} package"), info)?;
                scenes.push((name.to_string(), scene));
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
