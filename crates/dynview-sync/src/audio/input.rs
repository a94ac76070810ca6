//! Checks of the tracks before any work: every problem is an error naming the camera.

use serde::{Deserialize, Serialize};

use super::options::{MAX_SAMPLE_RATE_HZ, MAX_TRACK_S, MAX_TRACKS, MIN_SAMPLE_RATE_HZ, MIN_TRACK_S};
use crate::error::{SyncError, SyncResult};

/// One camera's sound, mono, starting with the camera's first video frame (shift it by the
/// stream's start before, if the sound and picture streams start apart).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AudioTrack {
    /// The camera's name (for errors and the report).
    pub camera: String,
    /// Samples per second; every track of one call must share it (16 kHz is plenty).
    pub sample_rate_hz: u32,
    /// The samples, any scale.
    pub samples: Vec<f32>,
}

/// A track whose samples all lie within this of their mean is silent (about -120 dB of a
/// full-scale ±1 signal).
const SILENCE_AMPLITUDE: f32 = 1e-6;

/// Errors for too few or too many tracks and for any unusable track.
pub(super) fn check_tracks(tracks: &[AudioTrack]) -> SyncResult<()> {
    if tracks.len() < 2 {
        return Err(SyncError::Failed(format!("aligning by sound needs at least 2 tracks, got {}", tracks.len())));
    }
    if tracks.len() > MAX_TRACKS {
        return Err(SyncError::Failed(format!("at most {MAX_TRACKS} sound tracks can be aligned at once, got {}", tracks.len())));
    }
    let first_rate_hz = tracks[0].sample_rate_hz;
    for track in tracks {
        let bad = |problem: String| Err(SyncError::Camera { camera: track.camera.clone(), problem });
        let rate_hz = track.sample_rate_hz;
        if !(MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&rate_hz) {
            return bad(format!("sound sample rate {rate_hz} Hz is not in [{MIN_SAMPLE_RATE_HZ}, {MAX_SAMPLE_RATE_HZ}] Hz"));
        }
        if rate_hz != first_rate_hz {
            return bad(format!(
                "sound sample rate {rate_hz} Hz differs from {first_rate_hz} Hz of camera {} (resample all tracks to one rate)",
                tracks[0].camera
            ));
        }
        if track.samples.is_empty() {
            return bad("no sound: the track has no samples".into());
        }
        let duration_s = track.samples.len() as f64 / f64::from(rate_hz);
        if duration_s > MAX_TRACK_S {
            return bad(format!("sound track is {duration_s:.0} s long, longer than {MAX_TRACK_S} s"));
        }
        if duration_s < MIN_TRACK_S {
            return bad(format!("sound track is {duration_s:.3} s long, shorter than {MIN_TRACK_S} s"));
        }
        if let Some(j) = track.samples.iter().position(|x| !x.is_finite()) {
            return bad(format!("sound sample {j} is not a number ({})", track.samples[j]));
        }
        let mean = track.samples.iter().map(|&x| f64::from(x)).sum::<f64>() / track.samples.len() as f64;
        let mean = mean as f32;
        if track.samples.iter().all(|x| (x - mean).abs() <= SILENCE_AMPLITUDE) {
            return bad("no sound: the track is silent".into());
        }
    }
    Ok(())
}
