//! The options of [`super::align_audio`] and the limits on its input.

use serde::{Deserialize, Serialize};

use crate::error::{SyncError, SyncResult};

/// Longest track accepted (s): two hours (a hostile input cannot make the alignment run for
/// days or allocate gigabytes).
pub const MAX_TRACK_S: f64 = 7200.0;
/// Shortest track accepted (s).
pub const MIN_TRACK_S: f64 = 1.0;
/// Most tracks in one call (every pair is measured).
pub const MAX_TRACKS: usize = 64;
/// Lowest sample rate accepted (Hz): below it claps and ball hits lose the detail that places
/// them to a millisecond.
pub const MIN_SAMPLE_RATE_HZ: u32 = 4_000;
/// Highest sample rate accepted (Hz); resample to 16 kHz before, it is faster and as precise.
pub const MAX_SAMPLE_RATE_HZ: u32 = 96_000;

/// Options of [`super::align_audio`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AudioOptions {
    /// Largest difference between two tracks' starts searched (s), at most [`MAX_TRACK_S`].
    pub max_offset_s: f64,
    /// Length of the windows along the recording in which each pair's offset is measured (s),
    /// 1 to 60; two or more of them in the overlap of a pair measure its drift, otherwise the
    /// rate is taken as 1.
    pub drift_window_s: f64,
    /// At most this many windows per pair (1 to 64), spread over the overlap.
    pub max_windows_per_pair: usize,
    /// Largest drift between two tracks, `|rate_b / rate_a - 1|` (0 to 0.01): sets how far from
    /// the coarse lag the windows search. Phones drift about 3e-4 (20 ms a minute) apart.
    pub max_rate_deviation: f64,
    /// Pairs less confident than this (0 to 1) are left out of the joint solve.
    pub min_confidence: f64,
    /// A pair that disagrees with the joint solution by more than this (s) is dropped while the
    /// others still connect every camera.
    pub outlier_threshold_s: f64,
}

impl Default for AudioOptions {
    fn default() -> Self {
        Self {
            max_offset_s: 60.0,
            drift_window_s: 10.0,
            max_windows_per_pair: 12,
            max_rate_deviation: 1e-3,
            min_confidence: 0.3,
            outlier_threshold_s: 0.005,
        }
    }
}

impl AudioOptions {
    /// An error naming the first option out of range.
    pub fn check(&self) -> SyncResult<()> {
        let bad = |option: &'static str, problem: String| Err(SyncError::Option { option, problem });
        if !(self.max_offset_s > 0.0 && self.max_offset_s <= MAX_TRACK_S) {
            return bad("max_offset_s", format!("{} is not in (0, {MAX_TRACK_S}] s", self.max_offset_s));
        }
        if !(1.0..=60.0).contains(&self.drift_window_s) {
            return bad("drift_window_s", format!("{} is not in [1, 60] s", self.drift_window_s));
        }
        if !(1..=64).contains(&self.max_windows_per_pair) {
            return bad("max_windows_per_pair", format!("{} is not in [1, 64]", self.max_windows_per_pair));
        }
        if !(0.0..=0.01).contains(&self.max_rate_deviation) {
            return bad("max_rate_deviation", format!("{} is not in [0, 0.01]", self.max_rate_deviation));
        }
        if !(0.0..=1.0).contains(&self.min_confidence) {
            return bad("min_confidence", format!("{} is not in [0, 1]", self.min_confidence));
        }
        if !(self.outlier_threshold_s > 0.0 && self.outlier_threshold_s <= 1.0) {
            return bad("outlier_threshold_s", format!("{} is not in (0, 1] s", self.outlier_threshold_s));
        }
        Ok(())
    }
}
