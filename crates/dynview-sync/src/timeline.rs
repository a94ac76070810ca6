//! The package's timeline: time steps at one frame rate over the stretch every camera filmed,
//! each step taking every camera's frame nearest to it in time.
//!
//! Frames are placed by their presentation timestamps, not by their index, so variable frame
//! rates and mixed rates (24 to 60 fps) land where they were filmed; a camera slower than the
//! timeline repeats a frame, a faster one skips frames.

use serde::{Deserialize, Serialize};

use crate::clock::Clock;
use crate::error::{SyncError, SyncResult};

/// Most time steps a timeline may have (a hostile timestamp cannot make it allocate gigabytes).
pub const MAX_STEPS: usize = 100_000;

/// The frame rates cameras and phones record at (fps): a variable-rate phone's mean near one of
/// them is taken as it.
pub const STANDARD_FPS: [f64; 11] = [15.0, 23.976, 24.0, 25.0, 29.97, 30.0, 48.0, 50.0, 59.94, 60.0, 120.0];

/// One camera's recorded frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraTimes {
    /// The camera's name (for errors).
    pub camera: String,
    /// Each frame's presentation time in the camera's own video, seconds from its first frame,
    /// in decoding order (must not decrease).
    pub frame_times_s: Vec<f64>,
}

impl CameraTimes {
    /// Frames evenly spaced at `fps`, as an image folder's frames are taken to be.
    pub fn evenly_spaced(camera: &str, frames: usize, fps: f64) -> Self {
        Self { camera: camera.to_owned(), frame_times_s: (0..frames).map(|j| j as f64 / fps).collect() }
    }

    /// The camera's frame rate: frames less one over the time from the first to the last (a
    /// variable rate's mean), taken as the standard rate ([`STANDARD_FPS`]) within 3% of it,
    /// else to a thousandth of a frame per second; `None` with fewer than two frames or no time
    /// between them.
    pub fn nominal_fps(&self) -> Option<f64> {
        let (first, last) = (self.frame_times_s.first()?, self.frame_times_s.last()?);
        let span = last - first;
        if !(span > 0.0 && span.is_finite()) {
            return None;
        }
        let mean = (self.frame_times_s.len() - 1) as f64 / span;
        let standard = STANDARD_FPS.iter().copied().min_by(|a, b| (a / mean - 1.0).abs().total_cmp(&(b / mean - 1.0).abs()))?;
        Some(if (standard / mean - 1.0).abs() <= 0.03 { standard } else { (mean * 1000.0).round() / 1000.0 })
    }

    fn check(&self) -> SyncResult<()> {
        let bad = |problem: String| Err(SyncError::Camera { camera: self.camera.clone(), problem });
        if self.frame_times_s.is_empty() {
            return bad("no frames".into());
        }
        if let Some(j) = self.frame_times_s.iter().position(|t| !t.is_finite()) {
            return bad(format!("frame {j} has no usable timestamp ({})", self.frame_times_s[j]));
        }
        if let Some(j) = self.frame_times_s.windows(2).position(|w| w[1] < w[0]) {
            return bad(format!(
                "frame {} is stamped {:.6} s, before frame {j} at {:.6} s (timestamps must not go back)",
                j + 1,
                self.frame_times_s[j + 1],
                self.frame_times_s[j]
            ));
        }
        Ok(())
    }
}

/// The package's time steps and the frame each camera contributes to each.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    /// Time steps per second.
    pub fps: f64,
    /// Per camera (in the order given), per time step, the index of the camera's frame.
    pub frames: Vec<Vec<usize>>,
    /// Per camera, its clock against this timeline (step `k` at `k / fps` seconds).
    pub clocks: Vec<Clock>,
    /// Per camera, the largest gap (s) between a step's time and the time its frame was filmed.
    pub max_error_s: Vec<f64>,
    /// Per camera (in the order given), per time step, where the step's moment falls between
    /// the camera's frames (for making the frame it would have filmed then).
    pub moments: Vec<Vec<Moment>>,
}

/// Where a moment falls in one camera's recording: between frame `before` and the next, a
/// `fraction` of the way (0 at `before`; always 0 before the first frame or after the last).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Moment {
    /// The frame filmed at or before the moment (the first frame before the recording starts).
    pub before: usize,
    /// How far (0 to below 1) from frame `before` to frame `before + 1` the moment lies.
    pub fraction: f64,
}

impl Moment {
    /// The moment `tau` in sorted `times` (not empty).
    pub fn locate(times: &[f64], tau: f64) -> Self {
        let after = times.partition_point(|t| *t <= tau);
        if after == 0 || after == times.len() {
            return Self { before: after.saturating_sub(1), fraction: 0.0 };
        }
        let (t0, t1) = (times[after - 1], times[after]);
        let fraction = if t1 > t0 { ((tau - t0) / (t1 - t0)).clamp(0.0, 1.0) } else { 0.0 };
        Self { before: after - 1, fraction }
    }
}

impl Timeline {
    /// Number of time steps.
    pub fn steps(&self) -> usize {
        self.frames.first().map_or(0, Vec::len)
    }

    /// The largest time error of any camera (s).
    pub fn largest_error_s(&self) -> f64 {
        self.max_error_s.iter().copied().fold(0.0, f64::max)
    }
}

/// Builds the timeline of `cameras` whose clocks against a common time are `clocks`: steps at
/// `fps` (default: the slowest camera's nominal rate, see [`default_fps`]) from the latest first frame to the
/// earliest last frame. Errors name the camera whose frames are unusable, or say when the
/// cameras share no stretch of time.
pub fn build(cameras: &[CameraTimes], clocks: &[Clock], fps: Option<f64>) -> SyncResult<Timeline> {
    build_from(cameras, clocks, fps, None)
}

/// [`build`] with the first step at common time `start_s` when given (it must lie in the span
/// every camera filmed; the steps still end where the first camera to stop stops).
pub fn build_from(cameras: &[CameraTimes], clocks: &[Clock], fps: Option<f64>, start_s: Option<f64>) -> SyncResult<Timeline> {
    if cameras.is_empty() {
        return Err(SyncError::Failed("no cameras".into()));
    }
    if clocks.len() != cameras.len() {
        return Err(SyncError::Failed(format!("{} clocks for {} cameras", clocks.len(), cameras.len())));
    }
    for (camera, clock) in cameras.iter().zip(clocks) {
        camera.check()?;
        if !clock.is_plausible() {
            return Err(SyncError::Camera { camera: camera.camera.clone(), problem: format!("implausible clock {clock:?}") });
        }
    }
    let fps = match fps {
        Some(f) if f.is_finite() && f > 0.0 && f <= 1000.0 => f,
        Some(f) => return Err(SyncError::Option { option: "fps", problem: format!("must be in (0, 1000], found {f}") }),
        None => default_fps(&cameras.iter().filter_map(CameraTimes::nominal_fps).collect::<Vec<_>>()),
    };
    let fps = if fps.is_finite() { fps } else { 30.0 };
    // Each camera's frames on the common time.
    let common: Vec<Vec<f64>> =
        cameras.iter().zip(clocks).map(|(c, clock)| c.frame_times_s.iter().map(|s| clock.timeline_time_s(*s)).collect()).collect();
    let first = |i: usize| common[i][0];
    let last = |i: usize| common[i][common[i].len() - 1];
    let start = (0..cameras.len()).map(first).fold(f64::NEG_INFINITY, f64::max);
    let end = (0..cameras.len()).map(last).fold(f64::INFINITY, f64::min);
    // Half a millisecond of slack: timestamps are rounded to their stream's time base.
    let slack_s = 5e-4;
    if end + slack_s < start {
        let latest = (0..cameras.len()).max_by(|a, b| first(*a).total_cmp(&first(*b))).unwrap_or(0);
        let earliest = (0..cameras.len()).min_by(|a, b| last(*a).total_cmp(&last(*b))).unwrap_or(0);
        return Err(SyncError::NoOverlap(format!(
            "camera {} starts {:.3} s after camera {} ends",
            cameras[latest].camera,
            start - end,
            cameras[earliest].camera
        )));
    }
    let start = match start_s {
        None => start,
        Some(s) if s.is_finite() && s >= start - slack_s && s <= end + slack_s => s,
        Some(s) => {
            return Err(SyncError::Option {
                option: "start-at",
                problem: format!("{s:.4} s is outside the {:.4} to {:.4} s every camera filmed (on the first camera's clock)", start, end),
            });
        }
    };
    let span_steps = ((end - start).max(0.0) * fps + slack_s * fps).floor();
    if span_steps >= MAX_STEPS as f64 {
        return Err(SyncError::Failed(format!("{span_steps} time steps at {fps} fps: more than {MAX_STEPS}")));
    }
    let steps = span_steps as usize + 1;
    let mut frames = Vec::with_capacity(cameras.len());
    let mut max_error_s = Vec::with_capacity(cameras.len());
    let mut moments = Vec::with_capacity(cameras.len());
    for times in &common {
        let mut picks = Vec::with_capacity(steps);
        let mut located = Vec::with_capacity(steps);
        let mut worst: f64 = 0.0;
        for k in 0..steps {
            let tau = start + k as f64 / fps;
            let j = nearest(times, tau);
            worst = worst.max((times[j] - tau).abs());
            picks.push(j);
            located.push(Moment::locate(times, tau));
        }
        frames.push(picks);
        max_error_s.push(worst);
        moments.push(located);
    }
    Ok(Timeline { fps, frames, clocks: clocks.iter().map(|c| c.shifted(start)).collect(), max_error_s, moments })
}

/// Rates this close (relative) count as one camera model's two namings (29.97 and 30 fps).
pub const SAME_RATE: f64 = 0.002;

/// The timeline's rate when none is given: the slowest of `rates` (a faster camera's frames
/// would otherwise repeat), except that where rates within [`SAME_RATE`] of it differ only as
/// 29.97 and 30 fps do, the one most cameras film at (the slowest on a tie): a variable-rate
/// phone taken as 29.97 among 30 fps phones would otherwise put every other camera a little off
/// the timeline. Infinite without rates.
pub fn default_fps(rates: &[f64]) -> f64 {
    let slowest = rates.iter().copied().fold(f64::INFINITY, f64::min);
    let count = |rate: f64| rates.iter().filter(|r| ((*r / rate) - 1.0).abs() < 1e-9).count();
    let mut near: Vec<f64> = rates.iter().copied().filter(|r| *r / slowest - 1.0 <= SAME_RATE).collect();
    near.sort_by(f64::total_cmp);
    near.dedup();
    near.into_iter().fold(slowest, |best, r| if count(r) > count(best) { r } else { best })
}

/// Index of the time in sorted `times` (not empty) nearest to `tau` (the earlier on a tie).
pub fn nearest(times: &[f64], tau: f64) -> usize {
    let after = times.partition_point(|t| *t < tau);
    match after {
        0 => 0,
        n if n == times.len() => n - 1,
        n => {
            if tau - times[n - 1] <= times[n] - tau {
                n - 1
            } else {
                n
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synchronized_equal_cameras_keep_every_frame_in_order() {
        let cameras = [CameraTimes::evenly_spaced("a", 30, 30.0), CameraTimes::evenly_spaced("b", 30, 30.0)];
        let timeline = build(&cameras, &[Clock::SYNCHRONIZED; 2], None).unwrap();
        assert_eq!(timeline.steps(), 30);
        assert_eq!(timeline.frames[1], (0..30).collect::<Vec<_>>());
        assert!(timeline.largest_error_s() < 1e-12);
        // Unequal counts: cut to the shorter, as prep did before timelines.
        let cameras = [CameraTimes::evenly_spaced("a", 30, 30.0), CameraTimes::evenly_spaced("b", 25, 30.0)];
        assert_eq!(build(&cameras, &[Clock::SYNCHRONIZED; 2], None).unwrap().steps(), 25);
    }

    #[test]
    fn mixed_rates_and_offsets_pick_the_frame_filmed_nearest_each_step() {
        // b runs at 60 fps and started 0.1 s before the timeline's time 0; c at 15 fps.
        let a = CameraTimes::evenly_spaced("a", 60, 30.0);
        let b = CameraTimes::evenly_spaced("b", 130, 60.0);
        let c = CameraTimes::evenly_spaced("c", 31, 15.0);
        let clocks = [Clock::SYNCHRONIZED, Clock { start_s: 0.1, rate: 1.0 }, Clock::SYNCHRONIZED];
        let timeline = build(&[a, b, c], &clocks, None).unwrap();
        assert_eq!(timeline.fps, 15.0, "the slowest camera's rate by default");
        // a ends at 59/30 s; c at 2.0 s; b at (129/60 - 0.1) s: the span is [0, 59/30].
        assert_eq!(timeline.steps(), 30);
        assert_eq!(timeline.frames[0][3], 6);
        assert_eq!(timeline.frames[1][3], 18, "0.2 s on the timeline is 0.3 s into b's video");
        assert_eq!(timeline.frames[2][3], 3);
        assert!(timeline.largest_error_s() < 1e-9);
        let at30 = build(
            &[CameraTimes::evenly_spaced("a", 60, 30.0), CameraTimes::evenly_spaced("c", 31, 15.0)],
            &[Clock::SYNCHRONIZED; 2],
            Some(30.0),
        )
        .unwrap();
        assert!((at30.max_error_s[1] - 1.0 / 30.0).abs() < 1e-9, "a 15 fps camera is up to a 30 fps step off");
    }

    #[test]
    fn the_span_starts_at_the_latest_camera_and_clocks_are_moved_there() {
        let a = CameraTimes::evenly_spaced("a", 90, 30.0);
        let b = CameraTimes::evenly_spaced("b", 90, 30.0);
        // b started 0.5 s after a: a's frame at 0.5 s shows what b's first frame shows.
        let timeline = build(&[a, b], &[Clock::SYNCHRONIZED, Clock { start_s: -0.5, rate: 1.0 }], None).unwrap();
        assert_eq!(timeline.frames[0][0], 15);
        assert_eq!(timeline.frames[1][0], 0);
        assert!((timeline.clocks[0].start_s - 0.5).abs() < 1e-12 && timeline.clocks[1].start_s.abs() < 1e-12);
        assert_eq!(timeline.steps(), 75);
    }

    #[test]
    fn a_variable_rate_counts_as_the_standard_rate_near_its_mean() {
        let jittered = CameraTimes { camera: "v".into(), frame_times_s: vec![0.0, 0.03, 0.075, 0.1, 0.13, 0.171, 0.2, 0.235] };
        assert_eq!(jittered.nominal_fps(), Some(29.97), "7 intervals in 0.235 s: 29.79 fps, the nearest standard rate within 3%");
        let odd = CameraTimes::evenly_spaced("o", 10, 37.0);
        assert_eq!(odd.nominal_fps(), Some(37.0));
        assert_eq!(CameraTimes::evenly_spaced("s", 10, 29.97).nominal_fps(), Some(29.97));
        assert_eq!(CameraTimes::evenly_spaced("one", 1, 30.0).nominal_fps(), None);
    }

    #[test]
    fn a_chosen_start_inside_the_span_moves_the_first_step_and_one_outside_is_refused() {
        let a = CameraTimes::evenly_spaced("a", 90, 30.0);
        let b = CameraTimes::evenly_spaced("b", 90, 30.0);
        let clocks = [Clock::SYNCHRONIZED, Clock { start_s: -0.5, rate: 1.0 }];
        let timeline = build_from(&[a.clone(), b.clone()], &clocks, None, Some(1.0)).unwrap();
        assert_eq!((timeline.frames[0][0], timeline.frames[1][0]), (30, 15));
        assert!((timeline.clocks[0].start_s - 1.0).abs() < 1e-12);
        assert_eq!(timeline.steps(), 60);
        let err = build_from(&[a, b], &clocks, None, Some(0.2)).unwrap_err().to_string();
        assert!(err.contains("start-at") && err.contains("0.2000"), "{err}");
    }

    #[test]
    fn variable_frame_rate_is_placed_by_timestamp() {
        let jittered = CameraTimes { camera: "v".into(), frame_times_s: vec![0.0, 0.03, 0.075, 0.1, 0.13, 0.171, 0.2] };
        let steady = CameraTimes::evenly_spaced("s", 7, 30.0);
        let timeline = build(&[steady, jittered], &[Clock::SYNCHRONIZED; 2], Some(30.0)).unwrap();
        assert_eq!(timeline.frames[1], vec![0, 1, 2, 3, 4, 5, 6]);
        assert!((timeline.max_error_s[1] - (0.075 - 2.0 / 30.0)).abs() < 1e-9);
    }

    #[test]
    fn a_drifting_clock_is_followed() {
        let rate = 1.0 + 20e-3 / 60.0;
        let drifting = CameraTimes::evenly_spaced("d", 30 * 70, 30.0);
        let steady = CameraTimes::evenly_spaced("s", 30 * 60, 30.0);
        let timeline = build(&[steady, drifting], &[Clock::SYNCHRONIZED, Clock { start_s: 0.0, rate }], None).unwrap();
        // After 60 s the drifting camera is 20 ms ahead: 0.6 of a frame, so it picks the next.
        assert_eq!(timeline.frames[1][30 * 59 + 29], 30 * 59 + 30);
        assert_eq!(timeline.frames[1][10], 10);
    }

    #[test]
    fn bad_input_is_named() {
        let a = CameraTimes::evenly_spaced("a", 10, 30.0);
        let empty = CameraTimes { camera: "e".into(), frame_times_s: vec![] };
        let err = build(&[a.clone(), empty], &[Clock::SYNCHRONIZED; 2], None).unwrap_err().to_string();
        assert!(err.contains("camera e") && err.contains("no frames"), "{err}");
        let back = CameraTimes { camera: "b".into(), frame_times_s: vec![0.0, 0.1, 0.05] };
        let err = build(&[a.clone(), back], &[Clock::SYNCHRONIZED; 2], None).unwrap_err().to_string();
        assert!(err.contains("camera b") && err.contains("frame 2"), "{err}");
        let nan = CameraTimes { camera: "n".into(), frame_times_s: vec![0.0, f64::NAN] };
        assert!(build(&[a.clone(), nan], &[Clock::SYNCHRONIZED; 2], None).unwrap_err().to_string().contains("camera n"));
        let late = Clock { start_s: -5.0, rate: 1.0 };
        let err = build(&[a.clone(), a.clone()], &[Clock::SYNCHRONIZED, late], None).unwrap_err().to_string();
        assert!(err.contains("no time covered"), "{err}");
        assert!(build(std::slice::from_ref(&a), &[Clock::SYNCHRONIZED], Some(f64::NAN)).is_err());
        let err = build(&[a.clone(), a], &[Clock::SYNCHRONIZED, Clock { start_s: 0.0, rate: 3.0 }], None).unwrap_err().to_string();
        assert!(err.contains("implausible"), "{err}");
    }

    #[test]
    fn a_moment_is_placed_between_the_frames_around_it() {
        let times = [0.0, 0.1, 0.3];
        assert_eq!(Moment::locate(&times, -1.0), Moment { before: 0, fraction: 0.0 });
        assert_eq!(Moment::locate(&times, 0.0), Moment { before: 0, fraction: 0.0 });
        let m = Moment::locate(&times, 0.25);
        assert_eq!(m.before, 1);
        assert!((m.fraction - 0.75).abs() < 1e-12, "{m:?}");
        assert_eq!(Moment::locate(&times, 0.3), Moment { before: 2, fraction: 0.0 });
        assert_eq!(Moment::locate(&times, 9.0), Moment { before: 2, fraction: 0.0 });
        // A camera that films a third of a frame early: every step a third of the way to its
        // next frame.
        let early = CameraTimes::evenly_spaced("early", 30, 30.0);
        let on_time = CameraTimes::evenly_spaced("on time", 30, 30.0);
        let clock = Clock { start_s: 1.0 / 90.0, rate: 1.0 };
        let timeline = build(&[on_time, early], &[Clock::SYNCHRONIZED, clock], None).unwrap();
        assert!(timeline.moments[0].iter().all(|m| m.fraction == 0.0));
        for (k, m) in timeline.moments[1].iter().enumerate().take(timeline.steps() - 1) {
            assert_eq!(m.before, k, "step {k}");
            assert!((m.fraction - 1.0 / 3.0).abs() < 1e-9, "step {k}: {m:?}");
        }
    }

    #[test]
    fn the_default_rate_is_the_slowest_unless_it_is_a_naming_of_the_common_one() {
        assert_eq!(default_fps(&[30.0, 15.0, 60.0]), 15.0);
        assert_eq!(default_fps(&[30.0, 29.97, 30.0, 60.0]), 30.0, "a 29.97 phone among 30 fps ones");
        assert_eq!(default_fps(&[29.97, 30.0]), 29.97, "a tie: the slowest");
        assert_eq!(default_fps(&[29.97, 29.97, 30.0]), 29.97);
        assert_eq!(default_fps(&[24.0, 25.0, 25.0]), 24.0, "24 and 25 fps are not one rate");
        assert!(default_fps(&[]).is_infinite());
    }
}
