//! What `ffprobe` says of a video: its streams' start times, its display rotation and its frames'
//! presentation times, read from the container without decoding.

use std::path::Path;
use std::process::Command;

use serde::Deserialize;

use crate::error::{SfmError, SfmResult};

/// Runs `ffprobe -v error <args> -of json <video>` and reads its answer as `T`; errors name the
/// file and say what the answer was `needed_for`.
fn ffprobe_json<T: serde::de::DeserializeOwned>(video: &Path, args: &[&str], needed_for: &str) -> SfmResult<T> {
    let decode = |problem: String| SfmError::Decode { path: video.to_path_buf(), problem };
    let output = Command::new("ffprobe")
        .args(["-v", "error"])
        .args(args)
        .args(["-of", "json"])
        .arg(video)
        .output()
        .map_err(|e| decode(format!("running ffprobe (needed {needed_for}): {e}")))?;
    if !output.status.success() {
        return Err(decode(format!("ffprobe: {}", String::from_utf8_lossy(&output.stderr).trim())));
    }
    serde_json::from_slice(&output.stdout).map_err(|e| decode(format!("ffprobe's answer: {e}")))
}

#[derive(Deserialize)]
struct Probe {
    #[serde(default)]
    streams: Vec<ProbeStream>,
}

#[derive(Deserialize)]
struct ProbeStream {
    codec_type: String,
    start_time: Option<String>,
}

/// The start times (s) of the first video and the first audio stream; `None` for the audio
/// when the file has no sound, `Err` when ffprobe is missing or cannot read the file.
pub(crate) fn stream_starts(video: &Path) -> SfmResult<(f64, Option<f64>)> {
    let decode = |problem: String| SfmError::Decode { path: video.to_path_buf(), problem };
    let probe: Probe = ffprobe_json(video, &["-show_entries", "stream=codec_type,start_time"], "to read the sound")?;
    let start = |kind: &str| {
        probe
            .streams
            .iter()
            .find(|s| s.codec_type == kind)
            .map(|s| s.start_time.as_deref().and_then(|t| t.parse::<f64>().ok()).unwrap_or(0.0))
    };
    let video_start = start("video").ok_or_else(|| decode("no video stream".into()))?;
    Ok((video_start, start("audio")))
}

#[derive(Deserialize)]
struct PacketProbe {
    #[serde(default)]
    packets: Vec<Packet>,
    #[serde(default)]
    streams: Vec<TimeBase>,
}

#[derive(Deserialize)]
struct Packet {
    pts: Option<i64>,
}

#[derive(Deserialize)]
struct TimeBase {
    time_base: String,
}

/// Every video frame's presentation time (s), in presentation order, from the first frame:
/// the container's packet timestamps in the stream's time base, sorted (packets come in
/// decoding order). Errors name the file: ffprobe missing or failing, a packet without a
/// timestamp, a bad time base.
pub fn frame_times_s(video: &Path) -> SfmResult<Vec<f64>> {
    let decode = |problem: String| SfmError::Decode { path: video.to_path_buf(), problem };
    let probe: PacketProbe =
        ffprobe_json(video, &["-select_streams", "v:0", "-show_entries", "packet=pts:stream=time_base"], "for the frames' timestamps")?;
    let base = probe.streams.first().map(|s| s.time_base.as_str()).unwrap_or("");
    let seconds_per_tick = base
        .split_once('/')
        .and_then(|(n, d)| Some(n.parse::<f64>().ok()? / d.parse::<f64>().ok()?))
        .filter(|s| s.is_finite() && *s > 0.0)
        .ok_or_else(|| decode(format!("video stream time base {base:?}")))?;
    let mut ticks = Vec::with_capacity(probe.packets.len());
    for (j, packet) in probe.packets.iter().enumerate() {
        ticks.push(packet.pts.ok_or_else(|| decode(format!("packet {j} has no timestamp")))?);
    }
    ticks.sort_unstable();
    let first = ticks.first().copied().unwrap_or(0);
    Ok(ticks.into_iter().map(|t| (t - first) as f64 * seconds_per_tick).collect())
}

#[derive(Deserialize)]
struct RotationProbe {
    #[serde(default)]
    streams: Vec<RotationStream>,
}

#[derive(Deserialize)]
struct RotationStream {
    #[serde(default)]
    side_data_list: Vec<SideData>,
    #[serde(default)]
    tags: std::collections::BTreeMap<String, String>,
}

#[derive(Deserialize)]
struct SideData {
    rotation: Option<f64>,
}

/// How far a player turns the video's pictures counter-clockwise to show them (0, 90, 180 or
/// 270 degrees): the display matrix a phone writes, else the older `rotate` tag (clockwise).
pub fn display_rotation_ccw_deg(video: &Path) -> SfmResult<u32> {
    let decode = |problem: String| SfmError::Decode { path: video.to_path_buf(), problem };
    let probe: RotationProbe = ffprobe_json(
        video,
        &["-select_streams", "v:0", "-show_entries", "stream_side_data=rotation:stream_tags=rotate"],
        "for the video's orientation",
    )?;
    let Some(stream) = probe.streams.first() else { return Ok(0) };
    let ccw = stream
        .side_data_list
        .iter()
        .find_map(|d| d.rotation)
        .or_else(|| stream.tags.get("rotate").and_then(|r| r.trim().parse::<f64>().ok()).map(|cw| -cw))
        .unwrap_or(0.0);
    if !ccw.is_finite() {
        return Err(decode(format!("display rotation {ccw}")));
    }
    let quarter = (ccw / 90.0).round();
    if (ccw - quarter * 90.0).abs() > 1.0 {
        return Err(decode(format!("display rotation of {ccw} degrees (only quarter turns are supported)")));
    }
    Ok((quarter as i64).rem_euclid(4) as u32 * 90)
}
