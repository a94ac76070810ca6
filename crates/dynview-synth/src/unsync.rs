//! Unsynchronized recordings: each input camera films the event on its own clock, as phones
//! started by hand would.
//!
//! Clock convention (the one of `dynview-sync`'s `Clock`): the event's timeline is the
//! synthetic event time (time step `t` of the synchronized event at `t / fps`). A camera's
//! `start_s` is the time in its own video (seconds from its first frame's presentation
//! timestamp) at which event time 0 was filmed, and its `rate` the seconds of its clock per
//! second of event time (1 without drift): its frame at video time `s` was filmed at event time
//! `(s - start_s) / rate`.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng, rngs::SmallRng};
use serde::{Deserialize, Serialize};

use dynview_core::{Camera, Intrinsics};

use crate::error::SynthError;
use crate::sound::SoundEvent;

/// Ticks per second of the variable-frame-rate camera's timestamps (the 90 kHz of MPEG): its
/// frame times are whole ticks, which its video stores exactly.
pub const VFR_TICKS_PER_S: f64 = 90_000.0;
/// Folder of the per-camera frame timestamps, `unsync/<camera>.json`.
pub const UNSYNC_DIR: &str = "unsync";
/// The clockwise turn players give the portrait camera's stored (landscape) frames to show them
/// upright, degrees (ffprobe reports the display matrix as a rotation of -90).
pub const PORTRAIT_ROTATION_DEG: u32 = 90;
/// Preset: the latest start of a camera before the event, seconds of its own clock.
pub const PHONES_MAX_START_S: f64 = 0.8;
/// Preset: how long cameras keep filming after the event, seconds of their own clock (range).
pub const PHONES_TAIL_S: [f64; 2] = [0.1, 0.6];
/// Preset: the variable-frame-rate camera's frame intervals vary by this share of the nominal.
pub const PHONES_VFR_JITTER: f64 = 0.25;
/// Preset: the drifting camera's clock gains this much per minute of event time (ms).
pub const PHONES_DRIFT_MS_PER_MIN: f64 = 20.0;
/// Preset: each camera's own microphone noise, this far below the event's sound (dB).
pub const PHONES_NOISE_DB: f64 = 30.0;

/// How the input cameras film the event when they are not synchronized (see the module docs
/// for the clock convention). Per-camera lists have one entry per input camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnsyncConfig {
    /// Per camera: the time in its own video (s from its first frame) at which event time 0 was
    /// filmed, its `start_s`; at least 0 (every camera starts before the event).
    pub start_offsets_s: Vec<f64>,
    /// Per camera: how long it keeps filming after the event's end (s of its own clock).
    pub tail_s: Vec<f64>,
    /// Per camera: its nominal frame rate (frames per second of its own clock).
    pub fps: Vec<f64>,
    /// The camera with a variable frame rate (frame intervals jittered around its nominal).
    pub vfr_camera: Option<usize>,
    /// How much the variable-frame-rate camera's intervals vary: each is its nominal times a
    /// uniform factor in `1 ± vfr_jitter` (0 to 0.5).
    pub vfr_jitter: f64,
    /// The camera filmed in portrait: its upright image is `height x width`, stored in the video
    /// as landscape pixels with rotation metadata.
    pub portrait_camera: Option<usize>,
    /// The camera whose clock drifts.
    pub drift_camera: Option<usize>,
    /// How much the drifting camera's clock gains per minute of event time (ms; negative: it
    /// loses).
    pub drift_ms_per_min: f64,
    /// Give every video an audio track (48 kHz mono): the event's sounds as heard at the camera.
    pub audio: bool,
    /// Each camera's own microphone noise, this far below the event's sound at it (dB).
    pub noise_db: f64,
}

impl UnsyncConfig {
    /// Phones started by hand: every camera starts a different, non-whole-frame time before
    /// the event (up to 0.8 s) and stops a different time after it; camera `1 % n` films at
    /// twice `fps`, camera `2 % n` at a variable frame rate (intervals ±25%), camera `3 % n` in
    /// portrait, camera `4 % n`'s clock gains 20 ms a minute; audio with noise 30 dB down. The
    /// times are drawn from `seed`.
    pub fn phones(cameras: usize, fps: f64, seed: u64) -> Self {
        let n = cameras.max(1);
        let fast = 1 % n;
        let camera_fps: Vec<f64> = (0..cameras).map(|c| if c == fast { 2.0 * fps } else { fps }).collect();
        let mut rng = SmallRng::seed_from_u64(seed ^ 0x0FF5_E75E_ED00_0001);
        let start_offsets_s = camera_fps
            .iter()
            .map(|&f| {
                // Whole frames plus a fraction well away from a whole frame.
                let whole = rng.random_range(0..(PHONES_MAX_START_S * f).floor().max(1.0) as u32);
                let start_s = (f64::from(whole) + rng.random_range(0.2..0.8)) / f;
                start_s.min(PHONES_MAX_START_S)
            })
            .collect();
        let tail_s = (0..cameras).map(|_| rng.random_range(PHONES_TAIL_S[0]..PHONES_TAIL_S[1])).collect();
        Self {
            start_offsets_s,
            tail_s,
            fps: camera_fps,
            vfr_camera: Some(2 % n),
            vfr_jitter: PHONES_VFR_JITTER,
            portrait_camera: Some(3 % n),
            drift_camera: Some(4 % n),
            drift_ms_per_min: PHONES_DRIFT_MS_PER_MIN,
            audio: true,
            noise_db: PHONES_NOISE_DB,
        }
    }

    /// The same cameras (frame rates, portrait phone, sound) as if they had been synchronized:
    /// each start moved to the nearest whole frame of `fps` (a step of the timeline), no
    /// variable frame rate, no drift. What the phones would give when timing costs nothing.
    pub fn synchronized(&self, fps: f64) -> Self {
        Self {
            start_offsets_s: self.start_offsets_s.iter().map(|s| (s * fps).round() / fps).collect(),
            vfr_camera: None,
            vfr_jitter: 0.0,
            drift_camera: None,
            drift_ms_per_min: 0.0,
            ..self.clone()
        }
    }

    /// Checks every option against `cameras` input cameras.
    pub fn validate(&self, cameras: usize) -> Result<(), SynthError> {
        let bad = |field, problem: String| Err(SynthError::Config { field, problem });
        for (field, list) in [("unsync.start_offsets_s", &self.start_offsets_s), ("unsync.tail_s", &self.tail_s), ("unsync.fps", &self.fps)]
        {
            if list.len() != cameras {
                return bad(field, format!("needs one value per camera ({cameras}), found {}", list.len()));
            }
        }
        for (field, list) in [("unsync.start_offsets_s", &self.start_offsets_s), ("unsync.tail_s", &self.tail_s)] {
            if let Some(v) = list.iter().find(|v| !(v.is_finite() && (0.0..=60.0).contains(*v))) {
                return bad(field, format!("each must be in [0, 60] s, found {v}"));
            }
        }
        if let Some(v) = self.fps.iter().find(|v| !(v.is_finite() && **v > 0.0 && **v <= 1000.0)) {
            return bad("unsync.fps", format!("each must be in (0, 1000], found {v}"));
        }
        for (field, camera) in [
            ("unsync.vfr_camera", self.vfr_camera),
            ("unsync.portrait_camera", self.portrait_camera),
            ("unsync.drift_camera", self.drift_camera),
        ] {
            if let Some(c) = camera.filter(|&c| c >= cameras) {
                return bad(field, format!("must name one of the {cameras} cameras (0..{cameras}), found {c}"));
            }
        }
        if !(self.vfr_jitter.is_finite() && (0.0..=0.5).contains(&self.vfr_jitter)) {
            return bad("unsync.vfr_jitter", format!("must be in [0, 0.5], found {}", self.vfr_jitter));
        }
        if !(self.drift_ms_per_min.is_finite() && self.drift_ms_per_min.abs() <= 1000.0) {
            return bad("unsync.drift_ms_per_min", format!("must be in [-1000, 1000] ms, found {}", self.drift_ms_per_min));
        }
        if !(self.noise_db.is_finite() && (0.0..=120.0).contains(&self.noise_db)) {
            return bad("unsync.noise_db", format!("must be in [0, 120] dB, found {}", self.noise_db));
        }
        Ok(())
    }
}

/// How one input camera filmed the event.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// Video time (s) at which event time 0 was filmed.
    pub start_s: f64,
    /// Seconds of the camera's clock per second of event time.
    pub rate: f64,
    /// Nominal frame rate.
    pub fps: f64,
    /// True when the frame intervals vary.
    pub vfr: bool,
    /// True when filmed in portrait.
    pub portrait: bool,
    /// Each frame's time in the camera's own video (s from its first frame).
    pub video_times_s: Vec<f64>,
}

impl Recording {
    /// The event time filmed at video time `video_s`.
    pub fn event_time_s(&self, video_s: f64) -> f64 {
        (video_s - self.start_s) / self.rate
    }

    /// The video time at which event time `event_s` was filmed.
    pub fn video_time_s(&self, event_s: f64) -> f64 {
        self.start_s + self.rate * event_s
    }

    /// Each frame's event time.
    pub fn event_times_s(&self) -> Vec<f64> {
        self.video_times_s.iter().map(|&s| self.event_time_s(s)).collect()
    }

    /// Length of the video (s): its last frame's time plus one nominal interval.
    pub fn duration_s(&self) -> f64 {
        self.video_times_s.last().copied().unwrap_or(0.0) + 1.0 / self.fps
    }

    /// The camera as it films: `landscape` (the rig's camera), turned to portrait when it is.
    pub fn camera(&self, landscape: Camera) -> Camera {
        if self.portrait { portrait_from_landscape(&landscape) } else { landscape }
    }
}

/// Every input camera's recording of an event of `cameras` cameras and `duration_s` (a validated
/// configuration, its `seed`) under `unsync`: frames
/// from video time 0 until `tail_s` after the event's end, at the nominal rate or, for the
/// variable-frame-rate camera, at jittered intervals in whole 90 kHz ticks drawn from the seed.
pub fn recordings(seed: u64, cameras: usize, duration_s: f64, unsync: &UnsyncConfig) -> Vec<Recording> {
    let mut rng = SmallRng::seed_from_u64(seed ^ 0x0FF5_E75E_ED00_0002);
    (0..cameras)
        .map(|c| {
            let fps = unsync.fps[c];
            let start_s = unsync.start_offsets_s[c];
            let rate = if unsync.drift_camera == Some(c) { 1.0 + unsync.drift_ms_per_min / 60_000.0 } else { 1.0 };
            let vfr = unsync.vfr_camera == Some(c);
            let end_s = start_s + rate * duration_s + unsync.tail_s[c];
            let mut video_times_s = Vec::new();
            if vfr {
                let mut ticks: u64 = 0;
                while ticks as f64 / VFR_TICKS_PER_S <= end_s {
                    video_times_s.push(ticks as f64 / VFR_TICKS_PER_S);
                    let interval_s = (1.0 + unsync.vfr_jitter * rng.random_range(-1.0..=1.0)) / fps;
                    ticks += ((interval_s * VFR_TICKS_PER_S).round() as u64).max(1);
                }
            } else {
                let count = (end_s * fps).floor() as u64 + 1;
                video_times_s.extend((0..count).map(|j| j as f64 / fps));
            }
            Recording { start_s, rate, fps, vfr, portrait: unsync.portrait_camera == Some(c), video_times_s }
        })
        .collect()
}

/// The same camera held in portrait: its upright image is `height x width`. The stored sensor
/// image is the landscape one (intrinsics of `landscape`), turned 90 degrees counter-clockwise
/// from the upright image, so the upright image's intrinsics are the sensor's turned clockwise:
/// `fx' = fy`, `fy' = fx`, `cx' = height - 1 - cy`, `cy' = cx`. The pose is the landscape
/// camera's (the upright image's x right, y down).
pub fn portrait_from_landscape(landscape: &Camera) -> Camera {
    let k = landscape.intrinsics;
    Camera {
        intrinsics: Intrinsics { fx: k.fy, fy: k.fx, cx: f64::from(landscape.height_px) - 1.0 - k.cy, cy: k.cx },
        camera_from_world: landscape.camera_from_world,
        width_px: landscape.height_px,
        height_px: landscape.width_px,
    }
}

/// The ground truth of an unsynchronized event, `synth.json`'s `time_alignment`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeAlignment {
    /// What the times refer to.
    pub timeline: String,
    /// Sample rate of the videos' audio tracks (Hz); `None` when they have none.
    pub audio_sample_rate_hz: Option<u32>,
    /// Per input camera.
    pub cameras: BTreeMap<String, CameraTiming>,
}

/// One input camera's recording, in `synth.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraTiming {
    /// Video time (s from its first frame) at which event time 0 was filmed.
    pub start_s: f64,
    /// Seconds of the camera's clock per second of event time.
    pub rate: f64,
    /// Nominal frame rate.
    pub fps: f64,
    /// True when its frame intervals vary.
    pub vfr: bool,
    /// True when filmed in portrait.
    pub portrait: bool,
    /// The clockwise turn players give the stored frames (degrees; 90 for portrait).
    pub rotation_deg: u32,
    /// Upright image width (px): what `input/<camera>/` holds and players show.
    pub width_px: u32,
    /// Upright image height (px).
    pub height_px: u32,
    /// Frames in its video and in `input/<camera>/`.
    pub frame_count: usize,
    /// Event time of its first frame (s; at most 0).
    pub first_event_time_s: f64,
    /// Event time of its last frame (s; past the event's end).
    pub last_event_time_s: f64,
    /// Travel time of sound from the scene's centre (`rig::LOOK_AT`) to the camera (s), for
    /// reference: the audio track is the video's clock plus each sound's own travel time.
    pub audio_delay_s: f64,
    /// Its frame timestamps, relative to the output folder.
    pub timestamps_file: String,
}

/// One camera's frame times and sound arrivals, `unsync/<camera>.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameTimes {
    /// The camera.
    pub camera: String,
    /// Its `start_s`.
    pub start_s: f64,
    /// Its `rate`.
    pub rate: f64,
    /// Per frame `j` (`input/<camera>/<j:05>.png`): its time in the video (s).
    pub video_times_s: Vec<f64>,
    /// Per frame: the event time it shows (s).
    pub event_times_s: Vec<f64>,
    /// The event's discrete sounds as they reach this camera, in order of arrival.
    pub sounds: Vec<SoundArrival>,
}

/// A discrete sound as one camera hears it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SoundArrival {
    /// The sound.
    pub event: SoundEvent,
    /// Event time at which it reaches the camera (s): its time plus distance / 343 m/s.
    pub arrival_event_s: f64,
    /// Video (and audio track) time at which it reaches the camera (s).
    pub arrival_video_s: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SynthConfig;
    use crate::rig::{LOOK_AT, Rig};

    fn event() -> SynthConfig {
        SynthConfig { cameras: 5, frames: 30, width: 64, height: 48, ..SynthConfig::default() }
    }

    #[test]
    fn phones_cover_the_event_on_their_own_clocks() {
        let config = event();
        let unsync = UnsyncConfig::phones(config.cameras, config.fps, 7);
        unsync.validate(config.cameras).unwrap();
        let recordings = recordings(config.seed, config.cameras, config.duration_s(), &unsync);
        for (c, r) in recordings.iter().enumerate() {
            assert!(r.start_s > 0.0 && r.start_s <= PHONES_MAX_START_S, "{c}: {}", r.start_s);
            let frac = (r.start_s * r.fps).fract();
            assert!((0.15..=0.85).contains(&frac), "camera {c} starts on a whole frame: {frac}");
            let times = r.event_times_s();
            assert!(times[0] <= 0.0 && *times.last().unwrap() >= config.duration_s(), "{c}: {times:?}");
            assert_eq!(r.video_times_s[0], 0.0);
        }
        let per_s = |r: &Recording| (r.video_times_s.len() - 1) as f64 / r.video_times_s.last().unwrap();
        let ratio = per_s(&recordings[1]) / per_s(&recordings[0]);
        assert!(recordings[1].fps == 60.0 && (ratio - 2.0).abs() < 1e-9, "{ratio}");
        assert!((recordings[4].rate - (1.0 + 20.0 / 60_000.0)).abs() < 1e-12 && recordings[0].rate == 1.0);
        assert!(recordings[3].portrait && !recordings[2].portrait);
        // The variable frame rate: intervals within ±25% of 1/30 s, not all alike, whole ticks.
        let vfr = &recordings[2];
        assert!(vfr.vfr);
        let intervals: Vec<f64> = vfr.video_times_s.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(intervals.iter().all(|d| (d * 30.0 - 1.0).abs() <= 0.25 + 1e-4), "{intervals:?}");
        let spread = intervals.iter().copied().fold(0.0, f64::max) - intervals.iter().copied().fold(1.0, f64::min);
        assert!(spread > 0.2 / 30.0, "{spread}");
        assert!(vfr.video_times_s.iter().all(|s| ((s * 9e4) - (s * 9e4).round()).abs() < 1e-6));
        // Different seeds, different starts.
        assert_ne!(UnsyncConfig::phones(5, 30.0, 8).start_offsets_s, unsync.start_offsets_s);
    }

    #[test]
    fn synchronized_phones_film_every_step_and_keep_their_cameras() {
        let config = event();
        let phones = UnsyncConfig::phones(config.cameras, config.fps, 7);
        let synchronized = phones.synchronized(config.fps);
        synchronized.validate(config.cameras).unwrap();
        let recordings = recordings(config.seed, config.cameras, config.duration_s(), &synchronized);
        for (c, r) in recordings.iter().enumerate() {
            // Every step of the event (k / fps) is a filmed frame's moment.
            let times = r.event_times_s();
            for k in 0..config.frames {
                let step = f64::from(k) / config.fps;
                assert!(times.iter().any(|t| (t - step).abs() < 1e-9), "camera {c} has no frame at step {k}");
            }
            assert_eq!(r.rate, 1.0);
            assert!(!r.vfr);
        }
        assert_eq!(
            (synchronized.fps.clone(), synchronized.portrait_camera, synchronized.audio),
            (phones.fps, phones.portrait_camera, phones.audio)
        );
    }

    #[test]
    fn video_and_event_times_invert_each_other() {
        let r = Recording { start_s: 0.37, rate: 1.0004, fps: 30.0, vfr: false, portrait: false, video_times_s: vec![0.0] };
        for e in [-0.3, 0.0, 1.7] {
            assert!((r.event_time_s(r.video_time_s(e)) - e).abs() < 1e-12);
        }
        assert!((r.event_time_s(0.37)).abs() < 1e-12);
    }

    #[test]
    fn the_portrait_camera_sees_the_same_rays_in_a_turned_image() {
        let rig = Rig::new(3, 64, 48, false, 1, 1.0);
        let landscape = rig.input(1, 0.0);
        let portrait = portrait_from_landscape(&landscape);
        assert_eq!((portrait.width_px, portrait.height_px), (48, 64));
        assert_eq!((portrait.intrinsics.cx, portrait.intrinsics.cy), (23.5, 31.5));
        for point in [LOOK_AT, LOOK_AT + glam::DVec3::new(0.5, 0.3, 0.2)] {
            let (p, dp) = portrait.project_world(point).unwrap();
            let (l, dl) = landscape.project_world(point).unwrap();
            let (kp, kl) = (portrait.intrinsics, landscape.intrinsics);
            assert!((dp - dl).abs() < 1e-12);
            assert!(((p.x - kp.cx) - (l.x - kl.cx)).abs() < 1e-9 && ((p.y - kp.cy) - (l.y - kl.cy)).abs() < 1e-9);
        }
    }

    #[test]
    fn bad_values_are_refused_with_their_field() {
        let good = UnsyncConfig::phones(4, 30.0, 1);
        good.validate(4).unwrap();
        let field = |u: UnsyncConfig, cameras: usize| match u.validate(cameras) {
            Err(SynthError::Config { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(field(good.clone(), 5), "unsync.start_offsets_s");
        assert_eq!(field(UnsyncConfig { fps: vec![30.0, 0.0, 30.0, 30.0], ..good.clone() }, 4), "unsync.fps");
        assert_eq!(field(UnsyncConfig { start_offsets_s: vec![0.1, -0.2, 0.0, 0.0], ..good.clone() }, 4), "unsync.start_offsets_s");
        assert_eq!(field(UnsyncConfig { tail_s: vec![0.1, f64::NAN, 0.0, 0.0], ..good.clone() }, 4), "unsync.tail_s");
        assert_eq!(field(UnsyncConfig { vfr_camera: Some(4), ..good.clone() }, 4), "unsync.vfr_camera");
        assert_eq!(field(UnsyncConfig { portrait_camera: Some(9), ..good.clone() }, 4), "unsync.portrait_camera");
        assert_eq!(field(UnsyncConfig { vfr_jitter: 0.6, ..good.clone() }, 4), "unsync.vfr_jitter");
        assert_eq!(field(UnsyncConfig { drift_ms_per_min: f64::INFINITY, ..good.clone() }, 4), "unsync.drift_ms_per_min");
        assert_eq!(field(UnsyncConfig { noise_db: -3.0, ..good }, 4), "unsync.noise_db");
    }
}
