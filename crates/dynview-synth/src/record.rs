//! The unsynchronized cameras' ground truth, microphone tracks and videos.

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;

use dynview_core::StageProgress;

use crate::files::write_json;
use crate::rig::{LOOK_AT, Rig};
use crate::scene::Object;
use crate::sound::{EventSound, SAMPLE_RATE_HZ, SPEED_OF_SOUND_M_S};
use crate::unsync::{CameraTiming, FrameTimes, PORTRAIT_ROTATION_DEG, Recording, SoundArrival, TimeAlignment, UNSYNC_DIR};
use crate::video::encode_recording;
use crate::{SynthConfig, SynthError};

/// What `time_alignment.timeline` says.
const TIMELINE: &str =
    "synthetic event time: time step t at t / fps; a camera's frame at video time s shows event time (s - start_s) / rate";

/// Writes `unsync/<camera>.json` for every recording and, with `videos`, each camera's video
/// with its frame times, orientation and (when `config.unsync.audio`) its microphone track;
/// returns the ground truth for `synth.json`.
pub(crate) fn write_recordings(
    config: &SynthConfig,
    rig: &Rig,
    objects: &[Object],
    recordings: &[Recording],
    root: &Path,
    videos: bool,
    progress: StageProgress,
) -> Result<TimeAlignment, SynthError> {
    let audio = videos && config.unsync.as_ref().is_some_and(|u| u.audio);
    let noise_db = config.unsync.as_ref().map(|u| u.noise_db);
    let times: Vec<Vec<f64>> = recordings.iter().map(Recording::event_times_s).collect();
    let from_s = times.iter().filter_map(|t| t.first()).copied().fold(0.0, f64::min);
    let to_s = times.iter().filter_map(|t| t.last()).copied().fold(config.duration_s(), f64::max);
    let sound = EventSound::new(objects, config.seed, from_s, to_s);
    let dir = root.join(UNSYNC_DIR);
    fs::create_dir_all(&dir).map_err(SynthError::io(&dir))?;
    let mut cameras = BTreeMap::new();
    for (c, (recording, event_times_s)) in recordings.iter().zip(times).enumerate() {
        let name = SynthConfig::camera_name(c);
        let mic_m = rig.input(c, 0.0).center_world();
        let mut sounds: Vec<SoundArrival> = sound
            .events
            .iter()
            .map(|event| {
                let arrival_event_s = event.arrival_s(mic_m);
                SoundArrival { event: *event, arrival_event_s, arrival_video_s: recording.video_time_s(arrival_event_s) }
            })
            .filter(|a| (0.0..recording.duration_s()).contains(&a.arrival_video_s))
            .collect();
        sounds.sort_by(|a, b| a.arrival_video_s.total_cmp(&b.arrival_video_s));
        let timestamps_file = format!("{UNSYNC_DIR}/{name}.json");
        let upright = recording.camera(rig.input(c, 0.0));
        cameras.insert(
            name.clone(),
            CameraTiming {
                start_s: recording.start_s,
                rate: recording.rate,
                fps: recording.fps,
                vfr: recording.vfr,
                portrait: recording.portrait,
                rotation_deg: if recording.portrait { PORTRAIT_ROTATION_DEG } else { 0 },
                width_px: upright.width_px,
                height_px: upright.height_px,
                frame_count: recording.video_times_s.len(),
                first_event_time_s: event_times_s.first().copied().unwrap_or(0.0),
                last_event_time_s: event_times_s.last().copied().unwrap_or(0.0),
                audio_delay_s: (LOOK_AT - mic_m).length() / SPEED_OF_SOUND_M_S,
                timestamps_file: timestamps_file.clone(),
            },
        );
        let frame_times = FrameTimes {
            camera: name.clone(),
            start_s: recording.start_s,
            rate: recording.rate,
            video_times_s: recording.video_times_s.clone(),
            event_times_s,
            sounds,
        };
        write_json(&root.join(&timestamps_file), &frame_times)?;
        if videos {
            progress("video", c as u64, recordings.len() as u64);
            let track = audio.then(|| {
                let sample_count = (recording.duration_s() * f64::from(SAMPLE_RATE_HZ)).ceil() as usize;
                let noise_seed = config.seed ^ ((c as u64 + 1) << 40) ^ 0x4D1C_0000;
                sound.track(mic_m, recording.start_s, recording.rate, sample_count, noise_db, noise_seed)
            });
            encode_recording(root, &name, recording, track.as_deref())?;
        }
    }
    if videos {
        progress("video", recordings.len() as u64, recordings.len() as u64);
    }
    Ok(TimeAlignment { timeline: TIMELINE.into(), audio_sample_rate_hz: audio.then_some(SAMPLE_RATE_HZ), cameras })
}
