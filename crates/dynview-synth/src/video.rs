//! Videos through the `ffmpeg` program: one per camera from its `input/<camera>/` frames.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::SynthError;
use crate::sound::SAMPLE_RATE_HZ;
use crate::unsync::{PORTRAIT_ROTATION_DEG, Recording, VFR_TICKS_PER_S};

/// Folder of the videos.
pub const VIDEOS_DIR: &str = "videos";
/// Time base of the variable-frame-rate videos' timestamps: one tick of [`VFR_TICKS_PER_S`].
const VFR_TIME_BASE: &str = "1:90000";
/// Time scale of the variable-frame-rate videos' mp4 track (ticks per second).
const VFR_TIMESCALE: &str = "90000";
/// The display rotation (counter-clockwise degrees, ffmpeg 6's `-display_rotation`) that turns
/// the portrait camera's stored frames [`PORTRAIT_ROTATION_DEG`] clockwise for display.
const PORTRAIT_DISPLAY_ROTATION_DEG: i32 = -(PORTRAIT_ROTATION_DEG as i32);
/// The mp4 `rotate` tag ffmpeg 5 turns into the same display matrix (ffprobe: rotation -90).
const PORTRAIT_ROTATE_TAG: u32 = 360 - PORTRAIT_ROTATION_DEG;

/// True when an `ffmpeg` binary runs.
pub fn ffmpeg_available() -> bool {
    Command::new("ffmpeg")
        .arg("-version")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// The frames of camera `name` as `videos/<name>.mp4` at a constant `fps`.
pub(crate) fn encode_video(root: &Path, name: &str, fps: f64) -> Result<(), SynthError> {
    let dir = root.join(VIDEOS_DIR);
    fs::create_dir_all(&dir).map_err(SynthError::io(&dir))?;
    let mut command = Command::new("ffmpeg");
    command
        .args(["-y", "-loglevel", "error", "-framerate", &fps.to_string(), "-i"])
        .arg(root.join("input").join(name).join("%05d.png"))
        .args(["-c:v", "libx264", "-preset", "veryfast", "-crf", "14", "-pix_fmt", "yuv420p"])
        .arg(dir.join(format!("{name}.mp4")));
    run(command, name, &dir)
}

/// The frames of camera `name` as `videos/<name>.mp4` with the frame times of `recording`
/// (a constant-rate camera at its rate; a variable-rate one through ffmpeg's concat demuxer with
/// each frame's duration, passed through to the file), stored in landscape with rotation
/// metadata when the camera filmed in portrait, and with `audio` (samples at 48 kHz from video
/// time 0) as an AAC track.
pub(crate) fn encode_recording(root: &Path, name: &str, recording: &Recording, audio: Option<&[f32]>) -> Result<(), SynthError> {
    let dir = root.join(VIDEOS_DIR);
    fs::create_dir_all(&dir).map_err(SynthError::io(&dir))?;
    let mut temporary: Vec<PathBuf> = Vec::new();
    let result = encode_recording_with(root, &dir, name, recording, audio, &mut temporary);
    for path in temporary {
        let _ = fs::remove_file(path);
    }
    result
}

fn encode_recording_with(
    root: &Path,
    dir: &Path,
    name: &str,
    recording: &Recording,
    audio: Option<&[f32]>,
    temporary: &mut Vec<PathBuf>,
) -> Result<(), SynthError> {
    let output = dir.join(format!("{name}.mp4"));
    let mut command = Command::new("ffmpeg");
    command.args(["-y", "-loglevel", "error", "-nostdin"]);
    if recording.vfr {
        let list = dir.join(format!(".{name}.ffconcat"));
        temporary.push(list.clone());
        fs::write(&list, concat_list(name, recording)).map_err(SynthError::io(&list))?;
        command.args(["-f", "concat", "-safe", "0", "-i"]).arg(&list);
    } else {
        command.args(["-framerate", &recording.fps.to_string(), "-i"]).arg(root.join("input").join(name).join("%05d.png"));
    }
    if let Some(samples) = audio {
        let raw = dir.join(format!(".{name}.f32"));
        temporary.push(raw.clone());
        fs::write(&raw, crate::sound::f32le_bytes(samples)).map_err(SynthError::io(&raw))?;
        command.args(["-f", "f32le", "-ar", &SAMPLE_RATE_HZ.to_string(), "-ac", "1", "-i"]).arg(&raw);
        command.args(["-map", "0:v:0", "-map", "1:a:0", "-c:a", "aac", "-b:a", "128k"]);
    }
    if recording.vfr {
        // Each frame at its own time; no B-frames, so the extra last frame is the last packet.
        command.args(["-fps_mode", "passthrough", "-enc_time_base:v", VFR_TIME_BASE, "-video_track_timescale", VFR_TIMESCALE, "-bf", "0"]);
    }
    if recording.portrait {
        // Upright portrait frames in; the sensor's landscape pixels (turned counter-clockwise) out.
        command.args(["-vf", "transpose=2"]);
    }
    command.args(["-c:v", "libx264", "-preset", "veryfast", "-crf", "14", "-pix_fmt", "yuv420p"]);
    if !(recording.vfr || recording.portrait) {
        command.arg(&output);
        return run(command, name, dir);
    }
    let encoded = dir.join(format!(".{name}.encoded.mp4"));
    temporary.push(encoded.clone());
    command.arg(&encoded);
    run(command, name, dir)?;
    // A remux: without the variable-rate camera's extra last frame, with the portrait camera's
    // rotation (ffmpeg 6 and later: `-display_rotation`; ffmpeg 5: the `rotate` tag, which it
    // keeps only when copying streams).
    let remux = |rotation: Option<bool>| {
        let mut remux = Command::new("ffmpeg");
        remux.args(["-y", "-loglevel", "error", "-nostdin"]);
        if rotation == Some(true) {
            remux.args(["-display_rotation:v:0", &PORTRAIT_DISPLAY_ROTATION_DEG.to_string()]);
        }
        remux.arg("-i").arg(&encoded).args(["-map", "0", "-c", "copy"]);
        if recording.vfr {
            remux.args(["-frames:v", &recording.video_times_s.len().to_string()]);
        }
        if rotation == Some(false) {
            remux.args(["-metadata:s:v:0", &format!("rotate={PORTRAIT_ROTATE_TAG}")]);
        }
        remux.arg(&output);
        remux
    };
    if !recording.portrait {
        return run(remux(None), name, dir);
    }
    run(remux(Some(true)), name, dir).or_else(|_| run(remux(Some(false)), name, dir))
}

/// An ffconcat list of the camera's frames (relative to `videos/`), read at the time base of
/// its timestamps, each lasting until the next frame's time (the last one its nominal
/// interval), and the last frame once more, so that the last one's duration reaches the file.
fn concat_list(name: &str, recording: &Recording) -> String {
    let micros: Vec<i64> = recording.video_times_s.iter().map(|s| (s * 1e6).round() as i64).collect();
    let interval_us = (1e6 / recording.fps).round() as i64;
    let mut list = String::from("ffconcat version 1.0\n");
    let last = micros.len().saturating_sub(1);
    for (j, t) in micros.iter().enumerate().chain(std::iter::once((last, &0))) {
        let duration_us = micros.get(j + 1).map_or(interval_us, |next| next - t);
        let _ = writeln!(list, "file '../input/{name}/{j:05}.png'\noption framerate {VFR_TICKS_PER_S}\nduration {duration_us}us");
    }
    list
}

fn run(mut command: Command, name: &str, dir: &Path) -> Result<(), SynthError> {
    let output = command.output().map_err(SynthError::io(dir))?;
    if !output.status.success() {
        return Err(SynthError::Video { camera: name.to_owned(), message: String::from_utf8_lossy(&output.stderr).trim().to_owned() });
    }
    Ok(())
}
