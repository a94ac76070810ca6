//! The lag of a pair in one window by GCC-PHAT: the cross-power spectrum of the two tracks'
//! samples, each strong bin scaled to unit magnitude (so every frequency votes equally and
//! reverberation and colouring do not widen the peak; bins at the noise level vote less), back to
//! time, peak found to a fraction of a sample on the band-limited correlation.

use super::fft::{FftWork, Weighting, parabolic_peak_offset, sidelobe_stats};
use super::line::LagLine;

/// Frequencies below this (Hz) are left out: wind, handling noise and hum differ per phone.
const LOW_CUT_HZ: f64 = 100.0;
/// The PHAT weighting's floor in median cross-spectrum magnitudes (see [`Weighting::Phat`]):
/// with 3, windows holding one tonal sound (a whistle, a ringing hit) among noise still peak,
/// and broadband sound keeps PHAT's sharp peak.
const PHAT_FLOOR: f64 = 3.0;
/// Fraction of each window's ends tapered by a half cosine (Tukey window).
const TAPER_FRACTION: f64 = 0.1;
/// Lags within this of the peak (s) are part of it, not sidelobes.
const PEAK_HALF_WIDTH_S: f64 = 0.001;
/// Most lags on each side of the peak used for the sidelobe statistics.
const MAX_SIDELOBE_LAGS: i64 = 16_384;
/// A window is measured when at least this fraction of track b's part of it exists.
const MIN_COVERAGE: f64 = 0.5;

/// Where and how to measure one window.
#[derive(Clone, Copy, Debug)]
pub(super) struct Window {
    /// The window's centre in track a (s).
    pub centre_a_s: f64,
    /// Its length (s).
    pub length_s: f64,
    /// How far from the predicted lag the peak is searched (s).
    pub radius_s: f64,
}

/// The lag one window measured.
#[derive(Clone, Copy, Debug)]
pub(super) struct WindowLag {
    /// The window's centre in track a (s).
    pub time_a_s: f64,
    /// Track b's time minus track a's time there (s).
    pub lag_s: f64,
    /// The GCC-PHAT peak's height over the sidelobes' mean in their standard deviations.
    pub peak_ratio: f64,
}

/// The lag at `window` by GCC-PHAT, with track b resampled to follow `predicted` (its slope
/// removes the drift within the window, its lag centres the search). `None` when the window
/// does not fit the tracks or the peak lies at the edge of the search.
pub(super) fn window_lag(
    fft: &mut FftWork,
    samples_a: &[f32],
    samples_b: &[f32],
    sample_rate_hz: f64,
    window: &Window,
    predicted: &LagLine,
) -> Option<WindowLag> {
    let length = ((window.length_s * sample_rate_hz).round() as usize).min(samples_a.len());
    if length < 16 {
        return None;
    }
    let first_a = ((window.centre_a_s * sample_rate_hz).round() as i64 - (length / 2) as i64).clamp(0, (samples_a.len() - length) as i64);
    let centre = length / 2;
    let centre_a_s = (first_a + centre as i64) as f64 / sample_rate_hz;
    let rate = 1.0 + predicted.slope;
    let centre_b = ((centre_a_s + predicted.lag_at(centre_a_s)) * sample_rate_hz).round();

    let mut segment_a = samples_a[first_a as usize..first_a as usize + length].to_vec();
    let mut covered = 0usize;
    let mut segment_b: Vec<f32> = (0..length)
        .map(|k| {
            let position = centre_b + (k as f64 - centre as f64) * rate;
            if position >= 0.0 && position <= (samples_b.len() - 1) as f64 {
                covered += 1;
            }
            sample_at(samples_b, position)
        })
        .collect();
    if (covered as f64) < MIN_COVERAGE * length as f64 {
        return None;
    }
    taper(&mut segment_a);
    taper(&mut segment_b);

    let radius = (window.radius_s * sample_rate_hz).ceil() as i64 + 1;
    let size = (length + radius as usize + 1).next_power_of_two();
    let low_bin = (LOW_CUT_HZ * size as f64 / sample_rate_hz).ceil() as usize;
    let correlation = fft.cross_correlation(&segment_a, &segment_b, size, Weighting::Phat { low_bin, floor_factor: PHAT_FLOOR });
    let at = |lag: i64| f64::from(correlation[lag.rem_euclid(size as i64) as usize]);
    let peak = (-radius..=radius).max_by(|&i, &j| at(i).total_cmp(&at(j)))?;
    if peak.abs() == radius {
        return None;
    }
    let lag = fft.refine_peak(peak as f64 + parabolic_peak_offset(at(peak - 1), at(peak), at(peak + 1)));
    let sidelobe_lags = (size as i64 - length as i64 - 1).min(length as i64 - 1).min(MAX_SIDELOBE_LAGS);
    let exclude = (PEAK_HALF_WIDTH_S * sample_rate_hz).ceil() as i64;
    let peak_ratio = match sidelobe_stats(&correlation, -sidelobe_lags..=sidelobe_lags, peak, exclude) {
        Some((mean, deviation)) if deviation > 0.0 => (at(peak) - mean) / deviation,
        _ => 0.0,
    };
    let time_b_s = (centre_b + lag * rate) / sample_rate_hz;
    Some(WindowLag { time_a_s: centre_a_s, lag_s: time_b_s - centre_a_s, peak_ratio })
}

/// The track's value at a fractional sample `position` by Catmull-Rom cubic interpolation
/// (exact at whole samples), zero outside the track.
fn sample_at(samples: &[f32], position: f64) -> f32 {
    let whole = position.floor();
    let t = (position - whole) as f32;
    let i = whole as i64;
    let get = |j: i64| if j >= 0 && (j as usize) < samples.len() { samples[j as usize] } else { 0.0 };
    let (p0, p1, p2, p3) = (get(i - 1), get(i), get(i + 1), get(i + 2));
    if t == 0.0 {
        return p1;
    }
    p1 + 0.5 * t * (p2 - p0 + t * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + t * (3.0 * (p1 - p2) + p3 - p0)))
}

/// Tapers the ends of `segment` by half cosines over [`TAPER_FRACTION`] of it.
fn taper(segment: &mut [f32]) {
    let ramp = ((segment.len() as f64 * TAPER_FRACTION * 0.5) as usize).max(1);
    let length = segment.len();
    for i in 0..ramp.min(length / 2) {
        let gain = (0.5 - 0.5 * (std::f64::consts::PI * (i as f64 + 0.5) / ramp as f64).cos()) as f32;
        segment[i] *= gain;
        segment[length - 1 - i] *= gain;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rustfft::num_complex::Complex;

    #[test]
    fn window_lag_finds_a_fractional_delay() {
        // White noise and the same noise delayed by 12.37 samples through a phase ramp on its
        // spectrum: an exact band-limited (circular) fractional delay.
        let rate_hz = 16_000.0;
        let size = 48_000;
        let mut state = 0x2545_f491_u32;
        let a: Vec<f32> = (0..size)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                state as f32 / u32::MAX as f32 - 0.5
            })
            .collect();
        let delay_samples = 12.37;
        let mut spectrum: Vec<Complex<f32>> = a.iter().map(|&x| Complex::new(x, 0.0)).collect();
        let mut planner = rustfft::FftPlanner::new();
        planner.plan_fft_forward(size).process(&mut spectrum);
        for (k, z) in spectrum.iter_mut().enumerate() {
            let frequency = if k <= size / 2 { k as f64 } else { k as f64 - size as f64 };
            let phase = -std::f64::consts::TAU * frequency * delay_samples / size as f64;
            *z = *z * Complex::from_polar(1.0, phase as f32) / size as f32;
        }
        planner.plan_fft_inverse(size).process(&mut spectrum);
        let b: Vec<f32> = spectrum.iter().map(|z| z.re).collect();

        let mut fft = FftWork::new();
        let window = Window { centre_a_s: 1.5, length_s: 1.0, radius_s: 0.005 };
        // A wrong slope in the prediction resamples b (cubic interpolation, poor near Nyquist)
        // and smears the peak over 3 samples, but the lag at the window's centre stays.
        for (slope, tolerance_samples) in [(0.0, 0.02), (2e-4, 0.2)] {
            let predicted = LagLine { time_a_s: 0.0, lag_s: 0.0, slope };
            let lag = window_lag(&mut fft, &a, &b, rate_hz, &window, &predicted).expect("a peak");
            let error_samples = lag.lag_s * rate_hz - delay_samples;
            assert!(error_samples.abs() < tolerance_samples, "slope {slope}: error {error_samples} samples");
            assert!(slope != 0.0 || lag.peak_ratio > 20.0, "peak ratio {}", lag.peak_ratio);
        }
    }
}
