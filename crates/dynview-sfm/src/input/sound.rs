//! A video's sound track, read through the `ffmpeg` and `ffprobe` programs, placed on the video's
//! own time (seconds from its first frame) for [`dynview_sync::audio`].

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};

use crate::error::{SfmError, SfmResult};
use crate::input::probe::stream_starts;

/// Sample rate the tracks are read at for alignment (Hz): enough for a sub-millisecond peak.
pub const ANALYSIS_RATE_HZ: u32 = 16_000;
/// Longest sound read from one video (s): two hours.
pub const MAX_SOUND_S: f64 = 7200.0;

/// A video's sound, mono at [`ANALYSIS_RATE_HZ`].
#[derive(Clone, Debug, PartialEq)]
pub struct Sound {
    /// The samples.
    pub samples: Vec<f32>,
    /// The video time (s from its first frame) of the first sample: the sound and picture
    /// streams of a file need not start together.
    pub start_in_video_s: f64,
}

/// True when `video` has a sound track (false also when it cannot be probed).
pub fn has_sound(video: &Path) -> bool {
    matches!(stream_starts(video), Ok((_, Some(_))))
}

/// Reads `video`'s first sound track, mixed to mono at [`ANALYSIS_RATE_HZ`]. Errors name the
/// file: no sound track, ffmpeg missing or failing, a track longer than [`MAX_SOUND_S`].
pub fn read_sound(video: &Path) -> SfmResult<Sound> {
    let decode = |problem: String| SfmError::Decode { path: video.to_path_buf(), problem };
    let (video_start_s, audio_start_s) = stream_starts(video)?;
    let audio_start_s = audio_start_s.ok_or_else(|| decode("no sound track (needed by --sync audio)".into()))?;
    let mut child = Command::new("ffmpeg")
        .args(["-v", "error", "-nostdin", "-i"])
        .arg(video)
        .args(["-map", "0:a:0", "-ac", "1", "-ar", &ANALYSIS_RATE_HZ.to_string(), "-f", "f32le", "-"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| decode(format!("running ffmpeg (needed to read the sound): {e}")))?;
    let max_bytes = (MAX_SOUND_S * f64::from(ANALYSIS_RATE_HZ)) as u64 * 4;
    let mut bytes = Vec::new();
    let stdout = child.stdout.take().ok_or_else(|| decode("ffmpeg gave no output".into()))?;
    stdout.take(max_bytes + 4).read_to_end(&mut bytes).map_err(|e| decode(format!("reading ffmpeg's output: {e}")))?;
    if bytes.len() as u64 > max_bytes {
        let _ = child.kill();
        let _ = child.wait();
        return Err(decode(format!("sound longer than {MAX_SOUND_S} s")));
    }
    let output = child.wait_with_output().map_err(|e| decode(format!("waiting for ffmpeg: {e}")))?;
    if !output.status.success() {
        return Err(decode(format!("ffmpeg could not decode the sound: {}", String::from_utf8_lossy(&output.stderr).trim())));
    }
    let samples: Vec<f32> = bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    if samples.is_empty() {
        return Err(decode("the sound track holds no samples".into()));
    }
    Ok(Sound { samples, start_in_video_s: audio_start_s - video_start_s })
}
