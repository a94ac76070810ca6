//! `cargo xtask demo --real`: the real captures of the shared data, each prepared twice under
//! `target/demo/`: with its calibration's poses (`NAME-calibrated`) and with our own structure
//! from motion (`NAME-sfm`), side by side. Panoptic's two basketball arcs (8 and 10 tripod
//! cameras, 75 frames) come first, then Pose2Sim's lab (4 portrait videos, 100 frames). A
//! preparation that fails is reported and skipped (our SfM finds no initial pair on Pose2Sim's
//! wide baseline today); the ones that succeed are served.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::bail;

use crate::dynview_prep::run_prep;
use crate::util::{run_step, workspace_root};

/// One real capture of the shared data, as the demo prepares it.
struct Capture {
    /// The scenes' name prefix (`NAME-calibrated`, `NAME-sfm`).
    name: &'static str,
    /// Its folder under `../shared/data`.
    folder: &'static str,
    /// The input prep reads, inside the folder (videos or one image folder per camera).
    input: &'static str,
    /// Working width of prep's frames, pixels.
    working_width_px: u32,
    /// Its calibration, inside the folder.
    calibration: Calibration,
}

/// How a capture's calibration reaches `prep --poses`.
enum Calibration {
    /// A COLMAP model folder, read as it is.
    Colmap(&'static str),
    /// A Qualisys file, converted by `dynview import` first.
    Qualisys(&'static str),
}

/// The captures, in the order they are prepared and listed: the Panoptic arcs first (the
/// paper's regime), then Pose2Sim (1088x1920 portrait videos, 540x953 frames).
const CAPTURES: [Capture; 3] = [
    Capture {
        name: "panoptic",
        folder: "panoptic-basketball-arc",
        input: "cams",
        working_width_px: 640,
        calibration: Calibration::Colmap("calibration"),
    },
    Capture {
        name: "panoptic-arc2",
        folder: "panoptic-basketball-arc2",
        input: "cams",
        working_width_px: 640,
        calibration: Calibration::Colmap("calibration"),
    },
    Capture {
        name: "pose2sim",
        folder: "pose2sim-multiperson",
        input: "videos",
        working_width_px: 540,
        calibration: Calibration::Qualisys("calibration/Calib.qca.txt"),
    },
];

/// Prepares every capture twice (prep skips finished stages; `fresh` starts over) and returns
/// the scenes to serve, by URL name.
pub fn prepare(dynview: &Path, fresh: bool) -> anyhow::Result<Vec<(String, PathBuf)>> {
    let demo = workspace_root().join("target/demo");
    let mut scenes = Vec::new();
    let mut failures = Vec::new();
    for capture in &CAPTURES {
        let source = workspace_root().join("../shared/data").join(capture.folder);
        let poses = calibration(dynview, capture, &source, &demo)?;
        let input = source.join(capture.input);
        let width = vec!["--working-width".to_string(), capture.working_width_px.to_string()];
        let calibrated = [vec!["--poses".to_string(), poses.display().to_string()], width.clone()].concat();
        for (kind, args) in [("calibrated", calibrated), ("sfm", width)] {
            let name = format!("{}-{kind}", capture.name);
            let out = demo.join(&name);
            match run_prep(dynview, &input, &out, &args, fresh, &format!("{name}: dynview prep on {}", input.display())) {
                Ok(scene) => {
                    let mut info = Command::new(dynview);
                    info.arg("info").arg(&scene);
                    run_step(&format!("check the {name} package"), info)?;
                    scenes.push((name, scene));
                }
                Err(e) => {
                    eprintln!("\n!!! {name}: dynview prep failed; going on without it.\n{e:#}\n");
                    failures.push(name);
                }
            }
        }
    }
    if scenes.is_empty() {
        bail!("no real capture could be prepared ({} failed; see the logs above)", failures.join(", "));
    }
    if !failures.is_empty() {
        println!("\nnot served (prep failed): {}", failures.join(", "));
    }
    Ok(scenes)
}

/// The poses `prep --poses` reads for `capture`: a COLMAP model as it is, a Qualisys
/// calibration converted by `dynview import` into `demo`.
fn calibration(dynview: &Path, capture: &Capture, source: &Path, demo: &Path) -> anyhow::Result<PathBuf> {
    let qualisys = match capture.calibration {
        Calibration::Colmap(model) => return Ok(source.join(model)),
        Calibration::Qualisys(file) => source.join(file),
    };
    std::fs::create_dir_all(demo)?;
    let poses = demo.join(format!("{}-calibration.json", capture.name));
    let mut import = Command::new(dynview);
    import.arg("import").arg(&qualisys).arg("--out").arg(&poses);
    run_step(&format!("the {} calibration as poses.json (dynview import)", capture.name), import)?;
    Ok(poses)
}
