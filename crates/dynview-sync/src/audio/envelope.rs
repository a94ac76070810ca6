//! Onset-strength envelopes and their correlation: the coarse lag of a pair over the whole
//! search range, and lags in segments along the overlap for a first guess of the drift.

use super::fft::{FftWork, Weighting, parabolic_peak_offset, sidelobe_stats};

/// Hop of the envelope (s): 10 ms, fine enough for a first lag within a few milliseconds.
pub(super) const HOP_S: f64 = 0.010;
/// Frame energies are floored at this fraction of the track's mean frame energy before the
/// logarithm, so digital silence does not make huge onsets.
const ENERGY_FLOOR: f64 = 1e-4;
/// Lags within this many hops of the envelope peak count as the peak, not its sidelobes.
const PEAK_HALF_WIDTH_HOPS: i64 = 5;
/// Length of a segment for the drift guess (s).
pub(super) const SEGMENT_S: f64 = 15.0;
/// Most segments for the drift guess.
const MAX_SEGMENTS: usize = 16;
/// A segment's lag is used when the envelopes' correlation coefficient at it reaches this.
const MIN_SEGMENT_CORRELATION: f64 = 0.15;

/// A track's onset strength in hops of [`HOP_S`], zero mean and unit variance.
pub(super) struct Envelope {
    /// The hop in seconds (`hop_samples` over the sample rate).
    pub hop_s: f64,
    /// One value per hop.
    pub values: Vec<f32>,
}

impl Envelope {
    /// The envelope of `samples` at `sample_rate_hz`: energy of the first difference (which
    /// favours claps and hits over rumble) per hop, log-compressed, its increase from the hop
    /// before (decreases count 0), standardised.
    pub(super) fn from_samples(samples: &[f32], sample_rate_hz: f64) -> Self {
        let hop_samples = ((HOP_S * sample_rate_hz).round() as usize).max(1);
        let hop_s = hop_samples as f64 / sample_rate_hz;
        let energies: Vec<f64> = samples
            .chunks_exact(hop_samples)
            .enumerate()
            .map(|(k, chunk)| {
                let mut previous = if k == 0 { chunk[0] } else { samples[k * hop_samples - 1] };
                let mut energy = 0.0f64;
                for &x in chunk {
                    let d = f64::from(x - previous);
                    energy += d * d;
                    previous = x;
                }
                energy / hop_samples as f64
            })
            .collect();
        let mean_energy = energies.iter().sum::<f64>() / energies.len().max(1) as f64;
        let floor = ENERGY_FLOOR * mean_energy + f64::MIN_POSITIVE;
        let logs: Vec<f64> = energies.iter().map(|e| (e + floor).ln()).collect();
        let mut onsets: Vec<f64> = Vec::with_capacity(logs.len());
        onsets.extend(logs.first().map(|_| 0.0));
        onsets.extend(logs.windows(2).map(|w| (w[1] - w[0]).max(0.0)));
        let count = onsets.len().max(1) as f64;
        let mean = onsets.iter().sum::<f64>() / count;
        let deviation = (onsets.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / count).sqrt();
        let scale = if deviation > 0.0 { 1.0 / deviation } else { 0.0 };
        let values = onsets.iter().map(|v| ((v - mean) * scale) as f32).collect();
        Self { hop_s, values }
    }

    /// The hops' count.
    pub(super) fn len(&self) -> usize {
        self.values.len()
    }
}

/// The best lag of a pair over the search range.
#[derive(Clone, Copy, Debug)]
pub(super) struct CoarseLag {
    /// Track b's time minus track a's time for the same sound (s).
    pub lag_s: f64,
    /// The peak's height over the sidelobes' mean, in their standard deviations.
    pub peak_ratio: f64,
}

/// The lags within ±`max_offset_s` (and with at least `min_overlap_s` of overlap) at which the
/// envelopes correlate best: up to `count` peaks, best first, each farther than a peak's width
/// from the better ones; `peak_width_s` of drift smear is added to the peak's width when
/// measuring the sidelobes. Empty when no lag qualifies.
pub(super) fn coarse_lags(
    fft: &mut FftWork,
    a: &Envelope,
    b: &Envelope,
    max_offset_s: f64,
    min_overlap_s: f64,
    peak_width_s: f64,
    count: usize,
) -> Vec<CoarseLag> {
    let (len_a, len_b) = (a.len() as i64, b.len() as i64);
    let size = (a.len() + b.len()).next_power_of_two();
    let correlation = fft.cross_correlation(&a.values, &b.values, size, Weighting::Plain);
    let at = |lag: i64| f64::from(correlation[lag.rem_euclid(size as i64) as usize]);
    let max_lag = (max_offset_s / a.hop_s).floor() as i64;
    let min_overlap = (min_overlap_s / a.hop_s).ceil() as i64;
    let overlap = |lag: i64| len_a.min(len_b - lag) - 0i64.max(-lag);
    let exclude = PEAK_HALF_WIDTH_HOPS + (peak_width_s / a.hop_s).ceil() as i64;
    let mut lags: Vec<i64> = (-max_lag..=max_lag).filter(|&lag| overlap(lag) >= min_overlap).collect();
    lags.sort_by(|&i, &j| at(j).total_cmp(&at(i)));
    let mut peaks: Vec<i64> = Vec::new();
    for lag in lags {
        if peaks.len() == count {
            break;
        }
        if peaks.iter().all(|p| (p - lag).abs() > exclude) {
            peaks.push(lag);
        }
    }
    peaks
        .into_iter()
        .map(|peak| {
            let offset = parabolic_peak_offset(at(peak - 1), at(peak), at(peak + 1));
            let peak_ratio = match sidelobe_stats(&correlation, -(len_b - 1)..len_a, peak, exclude) {
                Some((mean, deviation)) if deviation > 0.0 => (at(peak) - mean) / deviation,
                _ => 0.0,
            };
            CoarseLag { lag_s: (peak as f64 + offset) * a.hop_s, peak_ratio }
        })
        .collect()
}

/// Lags `(time in track a, lag)` (s) of segments of about [`SEGMENT_S`] tiling `[start_a_s,
/// end_a_s)` of track a, each searched within `radius_s` of `lag_s`; only segments whose
/// correlation is clear and not at the edge of the search. Empty with fewer than two segments.
pub(super) fn segment_lags(a: &Envelope, b: &Envelope, start_a_s: f64, end_a_s: f64, lag_s: f64, radius_s: f64) -> Vec<(f64, f64)> {
    let segments = (((end_a_s - start_a_s) / SEGMENT_S).floor().max(0.0) as usize).min(MAX_SEGMENTS);
    if segments < 2 {
        return Vec::new();
    }
    let hop_s = a.hop_s;
    let segment_hops = (end_a_s - start_a_s) / segments as f64 / hop_s;
    let first_lag = ((lag_s - radius_s) / hop_s).floor() as i64;
    let last_lag = ((lag_s + radius_s) / hop_s).ceil() as i64;
    let mut lags = Vec::new();
    for k in 0..segments {
        let from = ((start_a_s / hop_s + k as f64 * segment_hops).round() as usize).min(a.len());
        let to = ((start_a_s / hop_s + (k + 1) as f64 * segment_hops).round() as usize).min(a.len());
        let coefficient = |lag: i64| correlation_coefficient(&a.values[from..to], &b.values, from as i64 + lag);
        let scores: Vec<f64> = (first_lag..=last_lag).map(coefficient).collect();
        let Some(best) = (0..scores.len()).max_by(|&i, &j| scores[i].total_cmp(&scores[j])) else { continue };
        if best == 0 || best + 1 == scores.len() || scores[best] < MIN_SEGMENT_CORRELATION {
            continue;
        }
        let offset = parabolic_peak_offset(scores[best - 1], scores[best], scores[best + 1]);
        let time_a_s = (from + to) as f64 * 0.5 * hop_s;
        lags.push((time_a_s, (first_lag as f64 + best as f64 + offset) * hop_s));
    }
    lags
}

/// The correlation coefficient of `segment` with `values[start..start + segment.len()]`,
/// over the part of it inside `values` (0 when under half is).
fn correlation_coefficient(segment: &[f32], values: &[f32], start: i64) -> f64 {
    let (mut dot, mut norm_a, mut norm_b, mut count) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for (i, &x) in segment.iter().enumerate() {
        let j = start + i as i64;
        if j < 0 || j >= values.len() as i64 {
            continue;
        }
        let y = values[j as usize];
        dot += f64::from(x) * f64::from(y);
        norm_a += f64::from(x) * f64::from(x);
        norm_b += f64::from(y) * f64::from(y);
        count += 1;
    }
    if 2 * count < segment.len() || norm_a <= 0.0 || norm_b <= 0.0 {
        return 0.0;
    }
    dot / (norm_a * norm_b).sqrt()
}
