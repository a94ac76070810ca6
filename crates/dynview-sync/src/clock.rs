//! A camera's clock against the package's timeline.

use serde::{Deserialize, Serialize};

/// How one camera's own video time relates to the timeline: the frame filmed at timeline time
/// `tau` (seconds from the package's first time step) is at `start_s + rate * tau` in the
/// camera's video (seconds from its first frame).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    /// The time in the camera's own video, seconds from its first frame, at which the
    /// timeline's time 0 was filmed.
    pub start_s: f64,
    /// Seconds of the camera's clock per second of the timeline (1.0 without drift).
    pub rate: f64,
}

impl Clock {
    /// A clock that starts with the timeline and does not drift.
    pub const SYNCHRONIZED: Self = Self { start_s: 0.0, rate: 1.0 };

    /// The camera's video time (s) at timeline time `tau_s`.
    pub fn video_time_s(&self, tau_s: f64) -> f64 {
        self.start_s + self.rate * tau_s
    }

    /// The timeline time (s) at the camera's video time `video_s`.
    pub fn timeline_time_s(&self, video_s: f64) -> f64 {
        (video_s - self.start_s) / self.rate
    }

    /// The same clock with the timeline's origin moved to `tau0_s` of this timeline.
    pub fn shifted(&self, tau0_s: f64) -> Self {
        Self { start_s: self.video_time_s(tau0_s), rate: self.rate }
    }

    /// True when both numbers are finite and the rate is within 10% of 1 (a clock off by more
    /// is not a camera's drift but a wrong estimate).
    pub fn is_plausible(&self) -> bool {
        self.start_s.is_finite() && self.rate.is_finite() && (0.9..=1.1).contains(&self.rate)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn video_and_timeline_times_invert_each_other() {
        let clock = Clock { start_s: 1.25, rate: 1.0003 };
        for tau in [0.0, 0.5, 60.0] {
            assert!((clock.timeline_time_s(clock.video_time_s(tau)) - tau).abs() < 1e-12);
        }
        let moved = clock.shifted(2.0);
        assert!((moved.video_time_s(0.0) - clock.video_time_s(2.0)).abs() < 1e-12);
        assert!((moved.video_time_s(1.0) - clock.video_time_s(3.0)).abs() < 1e-12);
    }

    #[test]
    fn implausible_clocks_are_named() {
        assert!(Clock::SYNCHRONIZED.is_plausible());
        assert!(!Clock { start_s: f64::NAN, rate: 1.0 }.is_plausible());
        assert!(!Clock { start_s: 0.0, rate: 1.5 }.is_plausible());
    }
}
