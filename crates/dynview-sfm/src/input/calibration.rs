//! Known calibration: intrinsics (and distortion) given by the user as a `poses.json` or a
//! COLMAP model, and the undistortion of frames when a distortion is given.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use opencv::calib3d;
use opencv::core::Mat;
use opencv::prelude::*;
use rayon::prelude::*;

use dynview_ba::HeldIntrinsics;
use dynview_camera::Radial;
use dynview_core::StageProgress;
use dynview_core::fsutil::write_atomic;
use dynview_core::scene::manifest::PoseEntry;
use dynview_interchange::poses::{CameraPoses, EventPoses};

use crate::error::{SfmError, SfmResult};
use crate::input::frames::{CameraFrames, EventFrames, WORK_FRAME_EXTENSION, encode_work_frame, read_bgr};

/// Reads a `poses.json` file, a COLMAP model folder (text or binary), a Qualisys or a
/// Middlebury calibration (detected: `dynview_interchange::import`).
pub fn read_poses(path: &Path) -> SfmResult<EventPoses> {
    dynview_interchange::import::read_event_poses(path).map_err(|e| SfmError::Input { path: path.to_path_buf(), problem: e.to_string() })
}

/// The calibration of every input camera in `given`, checked against the frames' sizes.
pub fn calibration_for<'a>(given: &'a EventPoses, path: &Path, frames: &EventFrames) -> SfmResult<Vec<&'a CameraPoses>> {
    let bad = |problem: String| SfmError::Input { path: path.to_path_buf(), problem };
    frames
        .cameras
        .iter()
        .map(|camera| {
            let Some(known) = given.cameras.iter().find(|c| c.name == camera.name) else {
                let names: Vec<&str> = given.cameras.iter().map(|c| c.name.as_str()).collect();
                return Err(bad(format!("no camera {} (it has: {})", camera.name, names.join(", "))));
            };
            if (known.width, known.height) != (camera.width, camera.height) {
                return Err(bad(format!(
                    "camera {}: calibrated for {}x{} images, its frames are {}x{}",
                    camera.name, known.width, known.height, camera.width, camera.height
                )));
            }
            Ok(known)
        })
        .collect()
}

/// Each of `recorded`'s frames' pose in `known`, found by the frame's file name (`None` where
/// `known` has none for it).
pub fn recorded_frame_poses(known: &CameraPoses, recorded: &CameraFrames) -> Vec<Option<PoseEntry>> {
    let by_file: HashMap<&str, PoseEntry> = known.frames.iter().filter_map(|f| Some((f.file.as_str(), f.camera_from_world?))).collect();
    (0..recorded.files.len()).map(|k| by_file.get(recorded.file_name(k).as_str()).copied()).collect()
}

/// Intrinsics the user gave for one camera, which bundle adjustment keeps as given.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct KnownIntrinsics {
    /// The intrinsics (undistorted: the frames are undistorted first).
    pub intrinsics: Radial,
    /// A whole calibration (`--intrinsics`, `--poses`): every intrinsic is held. Otherwise a
    /// focal length alone (`--focal`): the focal is held and the principal point estimated as
    /// for any camera.
    pub calibrated: bool,
}

impl KnownIntrinsics {
    /// A focal length alone, the principal point at the centre of a `width` x `height` image.
    pub fn focal(focal_px: f64, width: u32, height: u32) -> Self {
        Self { intrinsics: Radial::centred(focal_px, width, height), calibrated: false }
    }

    /// What bundle adjustment holds.
    pub fn held(&self) -> HeldIntrinsics {
        if self.calibrated { HeldIntrinsics::ALL } else { HeldIntrinsics { focal: true, ..HeldIntrinsics::default() } }
    }
}

/// Known intrinsics by camera name, every one held as given.
pub type KnownCameras = BTreeMap<String, KnownIntrinsics>;

/// What bundle adjustment holds of camera `name`'s intrinsics (nothing when none were given).
pub fn held_intrinsics(known: &KnownCameras, name: &str) -> HeldIntrinsics {
    known.get(name).map(KnownIntrinsics::held).unwrap_or_default()
}

/// Known intrinsics by camera name from a calibration (undistorted: the frames are undistorted
/// first).
pub fn known_intrinsics(calibration: &[&CameraPoses]) -> KnownCameras {
    calibration
        .iter()
        .map(|c| (c.name.clone(), KnownIntrinsics { intrinsics: Radial::from_pinhole(&c.intrinsics.into()), calibrated: true }))
        .collect()
}

/// Undistorts the frames of every camera whose calibration has a distortion into
/// `out_dir/<camera>/<frame's file stem>.png` (same camera matrix, no distortion, lossless); returns the frame list
/// with those files. Finished frames are not redone.
pub fn undistort_frames(
    frames: &EventFrames,
    calibration: &[&CameraPoses],
    out_dir: &Path,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<EventFrames> {
    let mut out = frames.clone();
    for (camera, calib) in out.cameras.iter_mut().zip(calibration) {
        if calib.distortion.iter().all(|d| *d == 0.0) {
            continue;
        }
        let k = &calib.intrinsics;
        let matrix = Mat::from_slice_2d(&[[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]]).map_err(SfmError::cv("camera matrix"))?;
        let distortion = Mat::from_slice(&calib.distortion).and_then(|m| m.try_clone()).map_err(SfmError::cv("distortion"))?;
        let dir = out_dir.join(&camera.name);
        let stamp = serde_json::to_string(&(k, calib.distortion)).unwrap_or_default();
        let done = AtomicU64::new(0);
        let label = format!("undistort {}", camera.name);
        let total = camera.files.len() as u64;
        let files = camera
            .files
            .par_iter()
            .enumerate()
            .map(|(t, source)| {
                SfmError::check_interrupt(interrupt)?;
                // Named after the frame it shows (a time step's frame changes with the time
                // alignment, and later stages are keyed by frame names).
                let stem = source.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| format!("{t:05}"));
                let path = dir.join(format!("{stem}.{WORK_FRAME_EXTENSION}"));
                let stamp_path = dir.join(format!(".{stem}.calibration"));
                let stamp = format!("{stamp} {}", source.display());
                if !(path.is_file() && std::fs::read_to_string(&stamp_path).is_ok_and(|s| s == stamp)) {
                    let image = read_bgr(source)?;
                    let mut undistorted = Mat::default();
                    calib3d::undistort(&image, &mut undistorted, &matrix, &distortion, &matrix)
                        .map_err(SfmError::cv("undistorting a frame"))?;
                    write_atomic(&path, encode_work_frame(&undistorted)?.as_slice()).map_err(SfmError::io(&path))?;
                    write_atomic(&stamp_path, stamp.as_bytes()).map_err(SfmError::io(&stamp_path))?;
                }
                progress(&label, done.fetch_add(1, Ordering::Relaxed) + 1, total);
                Ok(path)
            })
            .collect::<SfmResult<Vec<_>>>()?;
        camera.files = files;
    }
    Ok(out)
}
