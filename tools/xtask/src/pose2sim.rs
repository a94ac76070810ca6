//! The Pose2Sim capture (`../shared/data/pose2sim-multiperson`) as `dynview prep` input: its
//! videos, the first frames of them as image folders, and its Qualisys calibration as a
//! `poses.json` with one pose per camera (the cameras stood on tripods).

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};
use dynview_core::poses::{CameraPoses, EventPoses, FramePose};

use crate::sfm_datasets::shared_data;
use crate::sfm_qualisys::{QualisysCamera, parse_qualisys_calibration};
use crate::util::describe;

/// Working width of prep's frames for the portrait 1088x1920 videos (960 would keep them
/// nearly full size; 540 gives 540x953 frames).
pub const WORKING_WIDTH_PX: u32 = 540;

/// The capture's folder.
pub fn source_dir() -> PathBuf {
    shared_data().join("pose2sim-multiperson")
}

/// The folder of its videos (`cam01.mp4` ... `cam04.mp4`).
pub fn videos_dir() -> PathBuf {
    source_dir().join("videos")
}

/// The cameras of the Qualisys calibration.
pub fn calibration() -> anyhow::Result<Vec<QualisysCamera>> {
    let path = source_dir().join("calibration/Calib.qca.txt");
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {} (is ../shared/data there?)", path.display()))?;
    parse_qualisys_calibration(&text, &path.display().to_string())
}

/// `poses.json` of the calibration's cameras whose serial is in `keep` (all when `None`): one
/// pose per camera, at the video size, with the calibration's distortion.
pub fn calibrated_poses(cameras: &[QualisysCamera], keep: Option<&[&str]>) -> EventPoses {
    EventPoses {
        cameras: cameras
            .iter()
            .filter(|c| keep.is_none_or(|k| k.contains(&c.serial.as_str())))
            .map(|c| CameraPoses {
                name: c.serial.clone(),
                width: c.width_px,
                height: c.height_px,
                intrinsics: c.intrinsics,
                distortion: c.distortion,
                // One pose for every frame; prep ignores the file name of a single pose.
                frames: vec![FramePose { file: "00000.jpg".into(), camera_from_world: Some(c.camera_from_world.into()) }],
            })
            .collect(),
    }
}

/// Writes [`calibrated_poses`] to `path` (validated; atomic).
pub fn write_calibrated_poses(path: &Path, keep: Option<&[&str]>) -> anyhow::Result<()> {
    let poses = calibrated_poses(&calibration()?, keep);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    }
    poses.write(path).with_context(|| format!("writing {}", path.display()))
}

/// Extracts the first `frames` frames of every camera's video into `out/<camera>/<i:05>.jpg`
/// (best JPEG quality), unless `out` already holds that many per camera.
pub fn extract_first_frames(out: &Path, frames: u32) -> anyhow::Result<()> {
    for camera in calibration()? {
        let folder = out.join(&camera.serial);
        let have = std::fs::read_dir(&folder).map(|d| d.filter_map(Result::ok).count()).unwrap_or(0);
        if have == frames as usize {
            continue;
        }
        if folder.exists() {
            std::fs::remove_dir_all(&folder).with_context(|| format!("cannot remove {}", folder.display()))?;
        }
        std::fs::create_dir_all(&folder).with_context(|| format!("cannot create {}", folder.display()))?;
        let video = videos_dir().join(format!("{}.mp4", camera.serial));
        let mut cmd = Command::new("ffmpeg");
        cmd.args(["-v", "error", "-nostdin", "-y", "-i"])
            .arg(&video)
            .args(["-frames:v", &frames.to_string(), "-q:v", "1", "-start_number", "0"])
            .arg(folder.join("%05d.jpg"));
        println!("    {}", describe(&cmd));
        let status = cmd.status().with_context(|| format!("cannot start {} (is ffmpeg installed?)", describe(&cmd)))?;
        if !status.success() {
            bail!("{} failed ({status})", describe(&cmd));
        }
        let got = std::fs::read_dir(&folder)?.count();
        if got != frames as usize {
            bail!("{}: {got} frames extracted from {}, expected {frames}", folder.display(), video.display());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const CALIBRATION: &str = include_str!("../../../tests/data/pose2sim-multiperson/Calib.qca.txt");

    #[test]
    fn calibrated_poses_validate_and_keep_the_chosen_cameras() {
        let cameras = parse_qualisys_calibration(CALIBRATION, "Calib.qca.txt").unwrap();
        let all = calibrated_poses(&cameras, None);
        all.validate().unwrap();
        assert_eq!(all.cameras.len(), 4);
        assert_eq!((all.cameras[0].width, all.cameras[0].height), (1088, 1920));
        assert!(all.cameras.iter().all(|c| c.frames.len() == 1 && c.distortion[0] < 0.0));
        let three = calibrated_poses(&cameras, Some(&["cam01", "cam03", "cam04"]));
        let names: Vec<&str> = three.cameras.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["cam01", "cam03", "cam04"]);
        let round_trip = EventPoses::from_json_bytes(three.to_json_string().as_bytes(), "poses.json").unwrap();
        assert_eq!(round_trip.cameras[2].frames[0].camera_from_world, Some(cameras[3].camera_from_world.into()));
    }
}
