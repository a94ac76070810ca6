//! The input event: one video per camera, or one image-sequence folder per camera, in one
//! folder. [`discover`] finds the cameras; [`decode_frames`] turns videos into numbered work
//! frames in the work folder, each with its presentation timestamp (image folders are used in
//! place and have none); [`crate::input::timing`] puts them on one timeline.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use opencv::core::{self, Mat, Vector};
use opencv::prelude::*;
use opencv::{imgcodecs, videoio};
use serde::{Deserialize, Serialize};

use dynview_core::StageProgress;
use dynview_core::fsutil::write_atomic;
use dynview_core::scene::manifest::is_safe_name;

use crate::error::{SfmError, SfmResult};
use crate::input::probe::{display_rotation_ccw_deg, frame_times_s};

/// File extensions read as videos.
pub const VIDEO_EXTENSIONS: &[&str] = &["mp4", "mov", "avi", "mkv", "webm", "m4v", "mpg", "mpeg"];
/// File extensions read as frames of an image-sequence folder.
pub const IMAGE_EXTENSIONS: &[&str] = &["png", "jpg", "jpeg", "tif", "tiff", "bmp", "webp"];
/// File extension of the work frames: the frames decoded from videos, the undistorted frames of
/// [`crate::input::calibration`] and the steps' working-size frames. PNG, lossless: a frame is
/// decoded once and compressed again only by the package's own encode (issue 33).
pub const WORK_FRAME_EXTENSION: &str = "png";
/// PNG compression level of the work frames (0-9): fast, the files are temporary.
const WORK_FRAME_PNG_COMPRESSION: i32 = 1;

/// Encodes a work frame (8-bit BGR) losslessly, as [`WORK_FRAME_EXTENSION`].
pub fn encode_work_frame(frame: &Mat) -> SfmResult<Vector<u8>> {
    let mut bytes = Vector::<u8>::new();
    let params = Vector::<i32>::from_slice(&[imgcodecs::IMWRITE_PNG_COMPRESSION, WORK_FRAME_PNG_COMPRESSION]);
    imgcodecs::imencode(&format!(".{WORK_FRAME_EXTENSION}"), frame, &mut bytes, &params).map_err(SfmError::cv("encoding a work frame"))?;
    Ok(bytes)
}
/// Most frames read from one camera (a hostile input cannot fill the disk).
pub const MAX_FRAMES: usize = 100_000;

/// Where a camera's frames come from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CameraSource {
    /// A video file.
    Video(PathBuf),
    /// A folder of images, in file-name order.
    Images(PathBuf),
}

/// A camera found in the input folder.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiscoveredCamera {
    /// The camera's name: the video's file stem or the folder's name.
    pub name: String,
    /// Its frames.
    pub source: CameraSource,
}

/// One camera's frames, ready for feature extraction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraFrames {
    /// The camera's name.
    pub name: String,
    /// Width of every frame in pixels.
    pub width: u32,
    /// Height of every frame in pixels.
    pub height: u32,
    /// Frame files in time order (absolute paths).
    pub files: Vec<PathBuf>,
}

impl CameraFrames {
    /// The file name of frame `t` (what COLMAP models and `poses.json` call the frame).
    pub fn file_name(&self, t: usize) -> String {
        self.files[t].file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
    }
}

/// Every camera's frames, all of the same count.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EventFrames {
    /// Cameras sorted by name.
    pub cameras: Vec<CameraFrames>,
}

impl EventFrames {
    /// Frames per camera.
    pub fn frame_count(&self) -> usize {
        self.cameras.first().map_or(0, |c| c.files.len())
    }
}

fn extension(path: &Path) -> String {
    path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default()
}

fn images_in(dir: &Path) -> SfmResult<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in fs::read_dir(dir).map_err(SfmError::io(dir))? {
        let path = entry.map_err(SfmError::io(dir))?.path();
        if path.is_file() && IMAGE_EXTENSIONS.contains(&extension(&path).as_str()) {
            files.push(path);
        }
    }
    files.sort();
    Ok(files)
}

/// Finds the cameras in `input`: every video file and every folder holding images. Hidden
/// entries and other files are ignored.
pub fn discover(input: &Path) -> SfmResult<Vec<DiscoveredCamera>> {
    let bad = |problem: String| SfmError::Input { path: input.to_path_buf(), problem };
    if !input.is_dir() {
        return Err(bad("not a folder (expected one video or one image folder per camera)".into()));
    }
    let mut cameras = Vec::new();
    let mut entries: Vec<PathBuf> = fs::read_dir(input).map_err(SfmError::io(input))?.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for path in entries {
        let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        if file_name.starts_with('.') {
            continue;
        }
        let (name, source) = if path.is_dir() {
            if images_in(&path)?.is_empty() {
                continue;
            }
            (file_name, CameraSource::Images(path.clone()))
        } else if VIDEO_EXTENSIONS.contains(&extension(&path).as_str()) {
            let stem = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            (stem, CameraSource::Video(path.clone()))
        } else {
            continue;
        };
        if !is_safe_name(&name) {
            return Err(SfmError::Input {
                path,
                problem: format!("camera name {name:?} must be 1 to 64 of A-Z a-z 0-9 _ - . (rename the file or folder)"),
            });
        }
        if cameras.iter().any(|c: &DiscoveredCamera| c.name == name) {
            return Err(SfmError::Input { path, problem: format!("two cameras are named {name:?}") });
        }
        cameras.push(DiscoveredCamera { name, source });
    }
    if cameras.is_empty() {
        return Err(bad(format!(
            "no cameras found: expected videos ({}) or folders of images ({})",
            VIDEO_EXTENSIONS.join(", "),
            IMAGE_EXTENSIONS.join(", ")
        )));
    }
    Ok(cameras)
}

/// Reads an image as 8-bit BGR, with an error naming the file.
pub fn read_bgr(path: &Path) -> SfmResult<Mat> {
    let decode = |problem: String| SfmError::Decode { path: path.to_path_buf(), problem };
    if !path.is_file() {
        return Err(decode("file is missing".into()));
    }
    let image = imgcodecs::imread(path, imgcodecs::IMREAD_COLOR).map_err(|e| decode(e.to_string()))?;
    if image.empty() {
        return Err(decode("not an image OpenCV can read".into()));
    }
    Ok(image)
}

/// What `done.json` of a decoded video holds: the video's size and each frame's timestamp.
#[derive(Serialize, Deserialize)]
struct DecodedVideo {
    video_bytes: u64,
    times_s: Vec<f64>,
}

/// Decodes `video` into `out_dir/<t:05>.png` (upright: a rotation in the file's metadata is
/// applied); returns the frame files and each frame's presentation time (s from the first
/// frame). A finished camera (its `done.json` names the same video size) is not decoded again.
fn decode_video(
    video: &Path,
    out_dir: &Path,
    camera: &str,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<(Vec<PathBuf>, Vec<f64>)> {
    let decode = |problem: String| SfmError::Decode { path: video.to_path_buf(), problem };
    let video_bytes = fs::metadata(video).map_err(SfmError::io(video))?.len();
    let done_file = out_dir.join("done.json");
    if let Ok(text) = fs::read_to_string(&done_file)
        && let Ok(done) = serde_json::from_str::<DecodedVideo>(&text)
        && done.video_bytes == video_bytes
    {
        let files: Vec<PathBuf> = (0..done.times_s.len()).map(|t| out_dir.join(format!("{t:05}.{WORK_FRAME_EXTENSION}"))).collect();
        if files.iter().all(|f| f.is_file()) {
            return Ok((files, done.times_s));
        }
    }
    // FFmpeg first (quiet and exact frame counts), then whatever backend OpenCV has.
    let mut capture = None;
    for backend in [videoio::CAP_FFMPEG, videoio::CAP_ANY] {
        if let Ok(c) = videoio::VideoCapture::from_file(video, backend)
            && c.is_opened().unwrap_or(false)
        {
            capture = Some(c);
            break;
        }
    }
    let Some(mut capture) = capture else { return Err(decode("OpenCV cannot open it as a video".into())) };
    let expected = capture.get(videoio::CAP_PROP_FRAME_COUNT).unwrap_or(0.0).max(0.0) as u64;
    fs::create_dir_all(out_dir).map_err(SfmError::io(out_dir))?;
    // Upright, as players show it: turned here by the container's display rotation (OpenCV
    // 4.6 does not apply it; asking it not to keeps newer versions from turning twice).
    let _ = capture.set(videoio::CAP_PROP_ORIENTATION_AUTO, 0.0);
    let turn = match display_rotation_ccw_deg(video)? {
        90 => Some(core::ROTATE_90_COUNTERCLOCKWISE),
        180 => Some(core::ROTATE_180),
        270 => Some(core::ROTATE_90_CLOCKWISE),
        _ => None,
    };
    let mut turned = Mat::default();
    let times_s = frame_times_s(video)?;
    let mut files = Vec::new();
    let mut frame = Mat::default();
    let mut size = None;
    while capture.read(&mut frame).map_err(|e| decode(e.to_string()))? {
        if frame.empty() {
            break;
        }
        SfmError::check_interrupt(interrupt)?;
        if let Some(code) = turn {
            core::rotate(&frame, &mut turned, code).map_err(|e| decode(format!("turning frame {}: {e}", files.len())))?;
            std::mem::swap(&mut frame, &mut turned);
        }
        let this_size = (frame.cols(), frame.rows());
        if *size.get_or_insert(this_size) != this_size {
            return Err(decode(format!("frame {} is {}x{}, earlier frames {:?}", files.len(), this_size.0, this_size.1, size)));
        }
        if files.len() >= MAX_FRAMES {
            return Err(decode(format!("more than {MAX_FRAMES} frames")));
        }
        let path = out_dir.join(format!("{:05}.{WORK_FRAME_EXTENSION}", files.len()));
        write_atomic(&path, encode_work_frame(&frame)?.as_slice()).map_err(SfmError::io(&path))?;
        files.push(path);
        progress(&format!("decode {camera}"), files.len() as u64, expected.max(files.len() as u64));
    }
    if files.is_empty() {
        return Err(decode("no frames could be decoded".into()));
    }
    if times_s.len() != files.len() {
        return Err(decode(format!("{} frames decoded but the container stamps {} (a damaged file?)", files.len(), times_s.len())));
    }
    let done = serde_json::to_string(&DecodedVideo { video_bytes, times_s: times_s.clone() }).unwrap_or_default();
    write_atomic(&done_file, done.as_bytes()).map_err(SfmError::io(&done_file))?;
    Ok((files, times_s))
}

/// Every camera's recorded frames, before they are put on one timeline.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedCamera {
    /// The camera's frames in recording order (counts differ between cameras).
    pub frames: CameraFrames,
    /// Where they came from.
    pub source: CameraSource,
    /// Each frame's presentation time in the video (s from its first frame); `None` for an
    /// image folder.
    pub times_s: Option<Vec<f64>>,
}

/// Makes every camera's frame list: videos are decoded into `frames_dir/<camera>/` with their
/// timestamps, image folders are listed.
pub fn decode_frames(
    cameras: &[DiscoveredCamera],
    frames_dir: &Path,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Vec<RecordedCamera>> {
    let mut out = Vec::new();
    for camera in cameras {
        let (files, times_s) = match &camera.source {
            CameraSource::Images(dir) => {
                let files = images_in(dir)?;
                if files.len() > MAX_FRAMES {
                    return Err(SfmError::Input { path: dir.clone(), problem: format!("more than {MAX_FRAMES} frames") });
                }
                (files, None)
            }
            CameraSource::Video(video) => {
                let (files, times) = decode_video(video, &frames_dir.join(&camera.name), &camera.name, progress, interrupt)?;
                (files, Some(times))
            }
        };
        let first = read_bgr(&files[0])?;
        let frames = CameraFrames { name: camera.name.clone(), width: first.cols() as u32, height: first.rows() as u32, files };
        out.push(RecordedCamera { frames, source: camera.source.clone(), times_s });
    }
    Ok(out)
}
