//! One pair of tracks: coarse lag, drift guess, then two passes of GCC-PHAT windows along the
//! overlap, each following the line the one before found.

use serde::{Deserialize, Serialize};

use super::AudioOptions;
use super::envelope::{self, Envelope};
use super::fft::FftWork;
use super::gcc::{self, Window, WindowLag};
use super::line::{LagLine, robust_line};

/// Shortest overlap of two tracks that is measured (s).
pub(super) const MIN_OVERLAP_S: f64 = 1.0;
/// Lags of the onset envelopes' correlation checked against the sound's fine structure.
const COARSE_CANDIDATES: usize = 4;
/// Most short windows that check one coarse candidate.
const CHECK_WINDOWS: usize = 128;
/// The short windows that check a coarse candidate lie within this of the overlap's middle (s):
/// drift within it stays inside the search.
const CHECK_SPAN_S: f64 = 20.0;
/// How far the coarse lag may be off (s): a few envelope hops.
const COARSE_TOLERANCE_S: f64 = 0.05;
/// Segments of the drift guess farther than this from its line are outliers (s).
const SEGMENT_TOLERANCE_S: f64 = 0.015;
/// Search radius of the first pass around the drift guess (s).
const FIRST_PASS_RADIUS_S: f64 = 0.025;
/// Windows of the first pass farther than this from its line are outliers (s).
const FIRST_PASS_TOLERANCE_S: f64 = 0.002;
/// The first pass's windows are this fraction of [`AudioOptions::drift_window_s`]: short
/// enough that the drift guess's error does not blur them.
const FIRST_PASS_WINDOW_FRACTION: f64 = 0.25;
/// Search radius of the second pass around the first pass's line (s).
const SECOND_PASS_RADIUS_S: f64 = 0.003;
/// Windows of the second pass farther than this from the final line are outliers (s).
const SECOND_PASS_TOLERANCE_S: f64 = 0.0005;
/// Length of the short windows that measure each second-pass window (s): about one sound each
/// (a clap or a hit rings for tens of ms).
const SHORT_WINDOW_S: f64 = 0.064;
/// Step between the short windows' centres (s).
const SHORT_HOP_S: f64 = 0.016;
/// Most short windows per pair, shared among its second-pass windows.
const MAX_SHORT_WINDOWS: usize = 512;
/// Search radius of the short windows around the first pass's line (s).
const SHORT_RADIUS_S: f64 = 0.010;
/// Fewest clear short windows whose median lag measures a second-pass window.
const MIN_SHORT_WINDOWS: usize = 8;
/// A window's GCC-PHAT peak counts from this peak-to-sidelobe ratio: unrelated sounds reach
/// about 4 over the few hundred lags searched.
const MIN_PEAK_RATIO: f64 = 7.0;
/// A window's peak counts fully from this peak-to-sidelobe ratio.
const FULL_PEAK_RATIO: f64 = 15.0;

/// The two tracks of a pair and what was computed from them once per track.
pub(super) struct PairInput<'a> {
    /// Index of track a.
    pub a: usize,
    /// Index of track b.
    pub b: usize,
    /// Track a's samples.
    pub samples_a: &'a [f32],
    /// Track b's samples.
    pub samples_b: &'a [f32],
    /// Track a's onset envelope.
    pub envelope_a: &'a Envelope,
    /// Track b's onset envelope.
    pub envelope_b: &'a Envelope,
    /// The tracks' sample rate.
    pub sample_rate_hz: f64,
}

/// What one pair of tracks measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairMeasurement {
    /// Index of the first track of the pair in the input (and in `AudioAlignment::cameras`).
    #[serde(rename = "track_a")]
    pub a: usize,
    /// Index of the second track, greater than `a`.
    #[serde(rename = "track_b")]
    pub b: usize,
    /// Track b's time minus track a's time for the same sound, from the onset envelopes (s).
    pub coarse_offset_s: f64,
    /// Peak-to-sidelobe ratio of the envelope correlation (about 4 for unrelated sounds).
    pub coarse_peak_ratio: f64,
    /// The time in track a (s) at which `offset_s` holds: the middle of the windows used.
    pub time_a_s: f64,
    /// Track b's time minus track a's time for the same sound, at `time_a_s` (s).
    pub offset_s: f64,
    /// Seconds of track b per second of track a (1 when not measured).
    pub rate_ratio: f64,
    /// True when two or more windows of [`AudioOptions::drift_window_s`] measured the rate.
    pub rate_measured: bool,
    /// Time in track a from the first to the last window used (s).
    pub span_s: f64,
    /// Windows whose GCC-PHAT peak agreed with the fitted line.
    pub windows_used: usize,
    /// Windows tried.
    pub windows_total: usize,
    /// How far to trust the measurement, 0 to 1.
    pub confidence: f64,
}

/// Measures the pair's offset and rate ratio (confidence 0 when nothing was found).
pub(super) fn measure_pair(fft: &mut FftWork, pair: &PairInput<'_>, options: &AudioOptions) -> PairMeasurement {
    let rate_hz = pair.sample_rate_hz;
    let duration_a_s = pair.samples_a.len() as f64 / rate_hz;
    let duration_b_s = pair.samples_b.len() as f64 / rate_hz;
    let max_drift_s = options.max_rate_deviation * duration_a_s.min(duration_b_s);
    let candidates =
        envelope::coarse_lags(fft, pair.envelope_a, pair.envelope_b, options.max_offset_s, MIN_OVERLAP_S, max_drift_s, COARSE_CANDIDATES);
    let coarse = best_heard_lag(fft, pair, &candidates, (duration_a_s, duration_b_s), options);
    let coarse_offset_s = coarse.map_or(0.0, |c| c.lag_s);
    let mut result = PairMeasurement {
        a: pair.a,
        b: pair.b,
        coarse_offset_s,
        coarse_peak_ratio: coarse.map_or(0.0, |c| c.peak_ratio),
        time_a_s: 0.0,
        offset_s: coarse_offset_s,
        rate_ratio: 1.0,
        rate_measured: false,
        span_s: 0.0,
        windows_used: 0,
        windows_total: 0,
        confidence: 0.0,
    };
    if coarse.is_none() {
        return result;
    }

    // Drift guess from envelope segments.
    let flat = LagLine { time_a_s: 0.0, lag_s: coarse_offset_s, slope: 0.0 };
    let (start_a_s, end_a_s) = overlap_in_a(&flat, duration_a_s, duration_b_s);
    result.time_a_s = 0.5 * (start_a_s + end_a_s);
    if end_a_s - start_a_s < MIN_OVERLAP_S {
        return result;
    }
    let segments =
        envelope::segment_lags(pair.envelope_a, pair.envelope_b, start_a_s, end_a_s, coarse_offset_s, COARSE_TOLERANCE_S + max_drift_s);
    let guess = robust_line(&segments, SEGMENT_TOLERANCE_S, options.max_rate_deviation).filter(|fit| fit.inlier_count >= 2);
    let (guess, guess_radius_s) = match guess {
        Some(fit) => (fit.line, FIRST_PASS_RADIUS_S),
        None => (LagLine { time_a_s: result.time_a_s, ..flat }, FIRST_PASS_RADIUS_S + 0.5 * max_drift_s),
    };

    // First pass: short windows around the guess.
    let (start_a_s, end_a_s) = overlap_in_a(&guess, duration_a_s, duration_b_s);
    result.windows_total = windows_count(end_a_s - start_a_s, options.drift_window_s, options.max_windows_per_pair);
    let short_s = (options.drift_window_s * FIRST_PASS_WINDOW_FRACTION).max(MIN_OVERLAP_S);
    let first = measure_windows(fft, pair, options, (start_a_s, end_a_s), short_s, guess_radius_s, &guess);
    let first: Vec<(f64, f64)> = first.iter().map(|w| (w.time_a_s, w.lag_s)).collect();
    let first_fit = robust_line(&first, FIRST_PASS_TOLERANCE_S, options.max_rate_deviation).filter(|fit| fit.inlier_count >= 1);
    let Some(first_fit) = first_fit else { return result };
    let (first_line, second_radius_s) = if first_fit.inlier_count >= 2 {
        (first_fit.line, SECOND_PASS_RADIUS_S)
    } else {
        (LagLine { slope: guess.slope, ..first_fit.line }, SECOND_PASS_RADIUS_S + 0.5 * max_drift_s)
    };

    // Second pass: full windows following the first pass's line.
    let (start_a_s, end_a_s) = overlap_in_a(&first_line, duration_a_s, duration_b_s);
    let second = measure_windows_by_sounds(fft, pair, options, (start_a_s, end_a_s), second_radius_s, &first_line);
    let windows_total = windows_count(end_a_s - start_a_s, options.drift_window_s, options.max_windows_per_pair);
    let points: Vec<(f64, f64)> = second.iter().map(|w| (w.time_a_s, w.lag_s)).collect();
    let Some(fit) = robust_line(&points, SECOND_PASS_TOLERANCE_S, options.max_rate_deviation) else {
        return PairMeasurement { windows_total, ..result };
    };
    let used: Vec<&WindowLag> = second.iter().zip(&fit.inliers).filter(|(_, inlier)| **inlier).map(|(w, _)| w).collect();
    let mut strengths: Vec<f64> =
        used.iter().map(|w| ((w.peak_ratio - MIN_PEAK_RATIO) / (FULL_PEAK_RATIO - MIN_PEAK_RATIO)).clamp(0.0, 1.0)).collect();
    strengths.sort_by(f64::total_cmp);
    let median_strength = strengths.get(strengths.len().saturating_sub(1) / 2).copied().unwrap_or(0.0);
    let times = used.iter().map(|w| w.time_a_s);
    let span_s = times.clone().fold(f64::NEG_INFINITY, f64::max) - times.fold(f64::INFINITY, f64::min);
    let rate_measured = fit.inlier_count >= 2;
    PairMeasurement {
        time_a_s: fit.line.time_a_s,
        offset_s: fit.line.lag_s,
        rate_ratio: if rate_measured { 1.0 + fit.line.slope } else { 1.0 },
        rate_measured,
        span_s: if span_s.is_finite() { span_s } else { 0.0 },
        windows_used: fit.inlier_count,
        windows_total,
        confidence: fit.inlier_count as f64 / windows_total.max(1) as f64 * median_strength,
        ..result
    }
}

/// The second pass's [`spread_windows`] of [`AudioOptions::drift_window_s`] over `overlap`,
/// each measured by its sounds: the median lag of
/// short windows inside it when at least [`MIN_SHORT_WINDOWS`] of them peak clearly (searched
/// [`SHORT_RADIUS_S`] around `line`), by GCC-PHAT over the whole window (within `radius_s`)
/// otherwise. A long window holds many sounds from several places, each heard with its own lag,
/// and its GCC-PHAT peak can fall milliseconds away from every one of them (2.6-4 ms on the
/// synthetic phones' 1.5 s recordings; over 10 s windows, lags that wander with the sounds and
/// tilt the drift); a short window holds about one sound, and the median is the lag most of the
/// window's sound is heard with.
fn measure_windows_by_sounds(
    fft: &mut FftWork,
    pair: &PairInput<'_>,
    options: &AudioOptions,
    overlap: (f64, f64),
    radius_s: f64,
    line: &LagLine,
) -> Vec<WindowLag> {
    let windows = spread_windows(overlap, options.drift_window_s, radius_s, options.max_windows_per_pair);
    let short_per_window = (MAX_SHORT_WINDOWS / windows.len().max(1)).max(MIN_SHORT_WINDOWS);
    windows
        .iter()
        .filter_map(|window| {
            let span = (window.centre_a_s - 0.5 * window.length_s, window.centre_a_s + 0.5 * window.length_s);
            short_windows_median(fft, pair, span, short_per_window, line).or_else(|| clear_lag(fft, pair, window, line))
        })
        .collect()
}

/// The clear short windows (every [`SHORT_HOP_S`], or spread wider to at most `most`) over
/// `(from_a_s, to_a_s)`, each searched within `radius_s` of `line`: per window, its lag less
/// the line's there (s) and its peak ratio.
fn short_windows(
    fft: &mut FftWork,
    pair: &PairInput<'_>,
    (from_a_s, to_a_s): (f64, f64),
    most: usize,
    radius_s: f64,
    line: &LagLine,
) -> Vec<(f64, f64)> {
    let usable_s = to_a_s - from_a_s - SHORT_WINDOW_S;
    if usable_s <= 0.0 {
        return Vec::new();
    }
    let count = ((usable_s / SHORT_HOP_S).floor() as usize + 1).min(most);
    (0..count)
        .filter_map(|k| {
            let centre_a_s = from_a_s + 0.5 * SHORT_WINDOW_S + (k as f64 + 0.5) * usable_s / count as f64;
            clear_lag(fft, pair, &Window { centre_a_s, length_s: SHORT_WINDOW_S, radius_s }, line)
        })
        .map(|w| (w.lag_s - line.lag_at(w.time_a_s), w.peak_ratio))
        .collect()
}

/// The median lag of the clear [`short_windows`] (up to `most`, searched [`SHORT_RADIUS_S`]
/// around `line`) over `(from_a_s, to_a_s)`, at the middle of the span, with their median peak
/// ratio; `None` with fewer than [`MIN_SHORT_WINDOWS`] clear.
fn short_windows_median(
    fft: &mut FftWork,
    pair: &PairInput<'_>,
    (from_a_s, to_a_s): (f64, f64),
    most: usize,
    line: &LagLine,
) -> Option<WindowLag> {
    let found = short_windows(fft, pair, (from_a_s, to_a_s), most, SHORT_RADIUS_S, line);
    if found.len() < MIN_SHORT_WINDOWS {
        return None;
    }
    let median = |mut values: Vec<f64>| {
        values.sort_by(f64::total_cmp);
        let middle = values.len() / 2;
        if values.len() % 2 == 1 { values[middle] } else { 0.5 * (values[middle - 1] + values[middle]) }
    };
    let time_a_s = 0.5 * (from_a_s + to_a_s);
    let shift_s = median(found.iter().map(|f| f.0).collect());
    Some(WindowLag { time_a_s, lag_s: line.lag_at(time_a_s) + shift_s, peak_ratio: median(found.iter().map(|f| f.1).collect()) })
}

/// Of the envelopes' best lags, the one at which most short windows around the overlap's middle
/// peak clearly: the lag at which the sound's fine structure agrees, not only a few onsets. On
/// a short recording of a few alike sounds (a ball's knocks), one knock of a track matched with
/// another knock of the other can correlate best in the envelopes; then few windows hold a
/// clear peak there, where at the true lag nearly all do (the murmur, the other knocks). The
/// envelopes' best wins ties. `None` without candidates.
fn best_heard_lag(
    fft: &mut FftWork,
    pair: &PairInput<'_>,
    candidates: &[envelope::CoarseLag],
    (duration_a_s, duration_b_s): (f64, f64),
    options: &AudioOptions,
) -> Option<envelope::CoarseLag> {
    if candidates.len() < 2 {
        return candidates.first().copied();
    }
    let mut best: Option<(usize, envelope::CoarseLag)> = None;
    for candidate in candidates {
        let line = LagLine { time_a_s: 0.0, lag_s: candidate.lag_s, slope: 0.0 };
        let (start_a_s, end_a_s) = overlap_in_a(&line, duration_a_s, duration_b_s);
        let middle_s = 0.5 * (start_a_s + end_a_s);
        let half_s = (0.5 * (end_a_s - start_a_s)).min(CHECK_SPAN_S);
        let span = (middle_s - half_s, middle_s + half_s);
        let radius_s = COARSE_TOLERANCE_S + options.max_rate_deviation * half_s;
        let clear = short_windows(fft, pair, span, CHECK_WINDOWS, radius_s, &line).len();
        if best.is_none_or(|(count, _)| clear > count) {
            best = Some((clear, *candidate));
        }
    }
    best.map(|(_, lag)| lag)
}

/// The stretch of track a's time (s) whose sound track b also holds under `line`.
fn overlap_in_a(line: &LagLine, duration_a_s: f64, duration_b_s: f64) -> (f64, f64) {
    // b's time t + lag(t) = (1 + slope) t + lag_s - slope * time_a_s must lie in [0, duration_b].
    let rate = 1.0 + line.slope;
    let intercept = line.lag_s - line.slope * line.time_a_s;
    let start = ((0.0 - intercept) / rate).max(0.0);
    let end = ((duration_b_s - intercept) / rate).min(duration_a_s);
    (start, end.max(start))
}

/// Windows of `length_s` that fit in `overlap_s`: as many as tile it, at least one, at most
/// `max_windows`.
fn windows_count(overlap_s: f64, length_s: f64, max_windows: usize) -> usize {
    ((overlap_s / length_s).floor().max(1.0) as usize).min(max_windows)
}

/// Windows of `length_s` (the overlap's length if shorter) spread evenly over `(start_a_s,
/// end_a_s)` ([`windows_count`] of them), each searched within `radius_s`; none when the
/// overlap is shorter than [`MIN_OVERLAP_S`].
fn spread_windows((start_a_s, end_a_s): (f64, f64), length_s: f64, radius_s: f64, max_windows: usize) -> Vec<Window> {
    let overlap_s = end_a_s - start_a_s;
    if overlap_s < MIN_OVERLAP_S {
        return Vec::new();
    }
    let count = windows_count(overlap_s, length_s, max_windows);
    let length_s = length_s.min(overlap_s);
    (0..count).map(|k| Window { centre_a_s: start_a_s + (k as f64 + 0.5) * overlap_s / count as f64, length_s, radius_s }).collect()
}

/// GCC-PHAT lags of the [`spread_windows`] of `length_s` over `overlap`, searched within
/// `radius_s` of `line`; only clear peaks.
fn measure_windows(
    fft: &mut FftWork,
    pair: &PairInput<'_>,
    options: &AudioOptions,
    overlap: (f64, f64),
    length_s: f64,
    radius_s: f64,
    line: &LagLine,
) -> Vec<WindowLag> {
    spread_windows(overlap, length_s, radius_s, options.max_windows_per_pair)
        .iter()
        .filter_map(|window| clear_lag(fft, pair, window, line))
        .collect()
}

/// The pair's GCC-PHAT lag at `window` (searched around `line`) when its peak is clear
/// ([`MIN_PEAK_RATIO`]).
fn clear_lag(fft: &mut FftWork, pair: &PairInput<'_>, window: &Window, line: &LagLine) -> Option<WindowLag> {
    gcc::window_lag(fft, pair.samples_a, pair.samples_b, pair.sample_rate_hz, window, line).filter(|w| w.peak_ratio >= MIN_PEAK_RATIO)
}
