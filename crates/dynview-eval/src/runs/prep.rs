//! Running `dynview prep` from xtask and reading what it wrote: `report.json`'s stage times,
//! the scene package's poses and cloud sizes, and one package's cameras aligned to another's.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::Context;
use dynview_core::Rigid3;
use dynview_core::scene::ScenePackage;

use crate::align::{PoseAccuracy, PoseEvalOptions, evaluate_poses, view_rotation};
use crate::runs::programs::run_logged;

/// The package folder `dynview prep` writes inside `--out`.
pub const SCENE_DIR: &str = "scene";
/// The run report `dynview prep` writes inside `--out`.
pub const REPORT_FILE: &str = "report.json";
/// The log xtask keeps of each prep run, inside `--out`.
pub const LOG_FILE: &str = "prep.log";

/// A finished `dynview prep`.
pub struct PrepRun {
    /// Its `--out` folder.
    pub out: PathBuf,
    /// Wall seconds of this invocation (small when prep reused finished stages).
    pub wall_secs: f64,
}

impl PrepRun {
    /// The scene package folder.
    pub fn scene_dir(&self) -> PathBuf {
        self.out.join(SCENE_DIR)
    }
}

/// Runs `dynview prep --input INPUT --out OUT EXTRA...`, its output appended to `OUT/prep.log`
/// (a failure's error quotes the log's end). With `fresh`, `OUT` is removed first; otherwise
/// prep itself skips the stages an earlier run finished.
pub fn run_prep(dynview: &Path, input: &Path, out: &Path, extra: &[String], fresh: bool) -> anyhow::Result<PrepRun> {
    if fresh && out.exists() {
        std::fs::remove_dir_all(out).with_context(|| format!("cannot remove {}", out.display()))?;
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut cmd = Command::new(dynview);
    cmd.arg("prep").arg("--input").arg(input).arg("--out").arg(out).args(extra);
    let log = out.join(LOG_FILE);
    let wall_secs = run_logged("dynview prep", cmd, &log)?;
    Ok(PrepRun { out: out.to_path_buf(), wall_secs })
}

/// Runs prep unless its package is there: an evaluation wants the stage times of the run that
/// made the package, which its `report.json` keeps (a re-run that skips stages would not).
pub fn prep_once(dynview: &Path, input: &Path, out: &Path, extra: &[String], fresh: bool) -> anyhow::Result<PrepRun> {
    if !fresh && out.join(SCENE_DIR).join("scene.json").is_file() {
        println!("reusing {} (--fresh redoes it)", out.display());
        return Ok(PrepRun { out: out.to_path_buf(), wall_secs: 0.0 });
    }
    println!("\n==> dynview prep --input {} --out {} {}", input.display(), out.display(), extra.join(" "));
    run_prep(dynview, input, out, extra, fresh)
}

/// A folder-name suffix for extra prep arguments (`+arg` each, characters other than letters,
/// digits and `.` as `_`), so that runs with different arguments keep their own folders.
pub fn prep_args_suffix(prep_args: &[String]) -> String {
    prep_args
        .iter()
        .map(|arg| {
            let name: String =
                arg.trim_start_matches('-').chars().map(|c| if c.is_ascii_alphanumeric() || c == '.' { c } else { '_' }).collect();
            format!("+{name}")
        })
        .collect()
}

/// `report.json`'s `stage_seconds`: `[["stage", seconds], ...]` in run order.
pub fn stage_seconds(out: &Path) -> anyhow::Result<Vec<(String, f64)>> {
    let path = out.join(REPORT_FILE);
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_stage_seconds(&text).with_context(|| format!("{}: field `stage_seconds`", path.display()))
}

/// Parses the `stage_seconds` field of a report's JSON text.
fn parse_stage_seconds(text: &str) -> anyhow::Result<Vec<(String, f64)>> {
    #[derive(serde::Deserialize)]
    struct Report {
        stage_seconds: Vec<(String, f64)>,
    }
    let report: Report = serde_json::from_str(text)?;
    Ok(report.stage_seconds)
}

/// Every camera's `camera_from_world` at every time step of a package, keyed
/// `<camera>/<t:05>` (the key both an estimated and a ground-truth package of one event share).
pub fn package_poses(package: &ScenePackage) -> anyhow::Result<BTreeMap<String, Rigid3>> {
    let mut poses = BTreeMap::new();
    for (c, camera) in package.manifest().cameras.iter().enumerate() {
        for t in 0..package.time_step_count() {
            poses.insert(format!("{}/{t:05}", camera.name), package.camera(c, t)?.camera_from_world);
        }
    }
    Ok(poses)
}

/// `estimated`'s cameras against the same cameras of `truth` (by name and time step), after
/// the similarity that aligns them (rotation from the orientations, scale and translation from
/// the centres: [`evaluate_poses`]'s default).
///
/// Each estimated pose is first turned by its camera's [`view_rotation`] against the truth's
/// intrinsics: the orientations compared are those of what each camera sees, so a principal
/// point that SfM traded for a rotation (the weak mode of an arc of cameras) does not tilt the
/// similarity, and a held-out camera mapped through it (with its true intrinsics) sees our world
/// as our cameras see it. The per-image rotation errors include that trade.
pub fn align_packages(estimated: &ScenePackage, truth: &ScenePackage) -> anyhow::Result<PoseAccuracy> {
    let truth_cameras = &truth.manifest().cameras;
    let mut poses = BTreeMap::new();
    for (c, camera) in estimated.manifest().cameras.iter().enumerate() {
        let reference = truth_cameras.iter().position(|r| r.name == camera.name);
        for t in 0..estimated.time_step_count() {
            let seen = estimated.camera(c, t)?;
            let mut pose = seen.camera_from_world;
            if let Some(r) = reference.filter(|_| t < truth.time_step_count()) {
                let wanted = truth.camera(r, t)?;
                let seen_at_size = seen.resized(wanted.width_px, wanted.height_px);
                let turn = view_rotation(&wanted.intrinsics, &seen_at_size.intrinsics, wanted.width_px, wanted.height_px);
                pose = Rigid3::new(turn * pose.rotation, turn * pose.translation);
            }
            poses.insert(format!("{}/{t:05}", camera.name), pose);
        }
    }
    evaluate_poses(&poses, &package_poses(truth)?, PoseEvalOptions::default())
        .with_context(|| format!("aligning the cameras of {} to {}", estimated.root().display(), truth.root().display()))
}

/// Points per time step of a package's clouds: (total, smallest, largest).
pub fn cloud_point_counts(package: &ScenePackage) -> (u64, u32, u32) {
    let counts: Vec<u32> = package.cloud_index().steps.iter().map(|s| s.point_count).collect();
    let total = counts.iter().map(|&n| u64::from(n)).sum();
    (total, counts.iter().copied().min().unwrap_or(0), counts.iter().copied().max().unwrap_or(0))
}

/// `stage_seconds` as a markdown table with a total row.
pub fn stage_table(stages: &[(String, f64)]) -> String {
    let mut s = String::from("| stage | seconds |\n| --- | ---: |\n");
    for (name, secs) in stages {
        s.push_str(&format!("| {name} | {secs:.1} |\n"));
    }
    s.push_str(&format!("| **total** | **{:.1}** |\n", stages.iter().map(|(_, secs)| secs).sum::<f64>()));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_stage_seconds_and_ignores_other_fields() {
        let text = r#"{"cameras": 6, "stage_seconds": [["frames", 1.5], ["poses", 20.25]], "more": {}}"#;
        let stages = parse_stage_seconds(text).unwrap();
        assert_eq!(stages, vec![("frames".to_string(), 1.5), ("poses".to_string(), 20.25)]);
        assert!(stage_table(&stages).contains("| **total** | **21.8** |"));
        assert!(parse_stage_seconds(r#"{"stage_seconds": [["frames"]]}"#).is_err());
    }
}
