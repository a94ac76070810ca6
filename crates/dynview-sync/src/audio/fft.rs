//! Cross-correlation of two real signals by one forward and one inverse complex FFT, with a
//! weighting of the cross-power spectrum (none for the envelopes, PHAT for the samples).

use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

/// The FFT plans and buffers reused by every correlation of one alignment.
pub(super) struct FftWork {
    planner: FftPlanner<f32>,
    signal: Vec<Complex<f32>>,
    spectrum: Vec<Complex<f32>>,
    scratch: Vec<Complex<f32>>,
    /// Bins `0..=size / 2` of the last weighted cross spectrum, for [`Self::refine_peak`].
    weighted: Vec<Complex<f64>>,
}

impl FftWork {
    /// Empty buffers; they grow to the largest transform asked for.
    pub(super) fn new() -> Self {
        Self { planner: FftPlanner::new(), signal: Vec::new(), spectrum: Vec::new(), scratch: Vec::new(), weighted: Vec::new() }
    }

    /// The circular cross-correlation `c[j] = sum_i a[i] * b[i + j]` of `a` and `b` zero-padded
    /// to `size` samples, with the cross-power spectrum `conj(A) * B` weighted first; lag `j` is
    /// at index `j mod size`. `a` and `b` are cut to `size`.
    pub(super) fn cross_correlation(&mut self, a: &[f32], b: &[f32], size: usize, weighting: Weighting) -> Vec<f32> {
        if size == 0 {
            return Vec::new();
        }
        self.signal.clear();
        self.signal.resize(size, Complex::new(0.0, 0.0));
        for (z, &x) in self.signal.iter_mut().zip(a) {
            z.re = x;
        }
        for (z, &x) in self.signal.iter_mut().zip(b) {
            z.im = x;
        }
        let forward = self.planner.plan_fft_forward(size);
        self.scratch.resize(forward.get_inplace_scratch_len(), Complex::new(0.0, 0.0));
        forward.process_with_scratch(&mut self.signal, &mut self.scratch);

        // z = a + i b, so A_k = (Z_k + conj Z_{n-k}) / 2 and B_k = (Z_k - conj Z_{n-k}) / 2i; the
        // weighted cross spectrum of two real signals is Hermitian, so half of it is computed.
        self.weighted.clear();
        self.weighted.extend((0..=size / 2).map(|k| {
            let z_k = self.signal[k];
            let z_mirror = self.signal[(size - k) % size].conj();
            let spectrum_a = (z_k + z_mirror) * 0.5;
            let spectrum_b = (z_k - z_mirror) * Complex::new(0.0, -0.5);
            let cross = spectrum_a.conj() * spectrum_b;
            Complex::new(f64::from(cross.re), f64::from(cross.im))
        }));
        weighting.apply(&mut self.weighted);
        self.spectrum.clear();
        self.spectrum.resize(size, Complex::new(0.0, 0.0));
        for (k, w) in self.weighted.iter().enumerate() {
            let weighted = Complex::new(w.re as f32, w.im as f32);
            if k == 0 || 2 * k == size {
                self.spectrum[k] = Complex::new(weighted.re, 0.0);
            } else {
                self.spectrum[k] = weighted;
                self.spectrum[size - k] = weighted.conj();
            }
        }
        let inverse = self.planner.plan_fft_inverse(size);
        self.scratch.resize(inverse.get_inplace_scratch_len(), Complex::new(0.0, 0.0));
        inverse.process_with_scratch(&mut self.spectrum, &mut self.scratch);
        let scale = 1.0 / size as f32;
        self.spectrum.iter().map(|z| z.re * scale).collect()
    }

    /// The maximum near `lag` (samples, from a parabola through the samples) of the last
    /// correlation taken as the band-limited function its spectrum defines, by Newton steps on
    /// its derivative: a parabola misplaces a sharp peak by up to a tenth of a sample, this
    /// does not. `lag` itself when the steps do not settle within half a sample of it.
    pub(super) fn refine_peak(&self, lag: f64) -> f64 {
        let size = 2 * self.weighted.len().saturating_sub(1);
        if size < 4 {
            return lag;
        }
        let mut tau = lag;
        for _ in 0..NEWTON_STEPS {
            // f(tau) = sum_k Re(G_k e^{i w_k tau}); f' and f'' by differentiating each term.
            let step = Complex::from_polar(1.0, std::f64::consts::TAU * tau / size as f64);
            let mut turn = Complex::new(1.0, 0.0);
            let (mut slope, mut curvature) = (0.0f64, 0.0f64);
            for (k, g) in self.weighted.iter().enumerate() {
                let term = g * turn;
                let omega = std::f64::consts::TAU * k as f64 / size as f64;
                slope -= omega * term.im;
                curvature -= omega * omega * term.re;
                turn *= step;
            }
            if curvature.is_nan() || curvature >= 0.0 {
                return lag;
            }
            tau -= slope / curvature;
            if !tau.is_finite() || (tau - lag).abs() > 0.5 {
                return lag;
            }
        }
        tau
    }
}

/// How the cross-power spectrum is weighted before going back to time.
#[derive(Clone, Copy, Debug)]
pub(super) enum Weighting {
    /// Not at all: the plain cross-correlation.
    Plain,
    /// Regularised PHAT: bins below `low_bin` dropped, every other bin divided by its magnitude
    /// plus `floor_factor` times the median magnitude, so bins well above the typical level
    /// count equally (PHAT's sharp peak) and bins at the noise level count less (a narrowband
    /// sound in a noisy window still makes a peak).
    Phat {
        /// First bin kept.
        low_bin: usize,
        /// The floor as a multiple of the median magnitude of the kept bins.
        floor_factor: f64,
    },
}

impl Weighting {
    fn apply(self, cross: &mut [Complex<f64>]) {
        let Self::Phat { low_bin, floor_factor } = self else { return };
        let low_bin = low_bin.min(cross.len());
        let mut magnitudes: Vec<f64> = cross[low_bin..].iter().step_by(MEDIAN_STRIDE).map(|z| z.norm_sqr().sqrt()).collect();
        let middle = magnitudes.len() / 2;
        let median = if magnitudes.is_empty() { 0.0 } else { *magnitudes.select_nth_unstable_by(middle, f64::total_cmp).1 };
        let floor = floor_factor * median + f64::MIN_POSITIVE;
        for (k, z) in cross.iter_mut().enumerate() {
            *z = if k < low_bin { Complex::new(0.0, 0.0) } else { *z / (z.norm_sqr().sqrt() + floor) };
        }
    }
}

/// The median magnitude of [`Weighting::Phat`] is taken over every this many bins (a close
/// enough median, at an eighth of the work).
const MEDIAN_STRIDE: usize = 8;

/// Newton steps of [`FftWork::refine_peak`].
const NEWTON_STEPS: usize = 3;

/// The peak of three neighbouring samples `(left, centre, right)` with `centre` the largest,
/// as an offset from the centre in samples (-0.5 to 0.5) by a parabola through them.
pub(super) fn parabolic_peak_offset(left: f64, centre: f64, right: f64) -> f64 {
    let curvature = left - 2.0 * centre + right;
    if curvature >= 0.0 || !curvature.is_finite() {
        return 0.0;
    }
    (0.5 * (left - right) / curvature).clamp(-0.5, 0.5)
}

/// Mean and standard deviation of `values` at the lags `lags` (indices of a circular
/// correlation of `values.len()` samples, negative ones wrapping), leaving out the lags within
/// `exclude` of `peak_lag`; `None` with fewer than 8 lags left.
pub(super) fn sidelobe_stats(values: &[f32], lags: impl Iterator<Item = i64>, peak_lag: i64, exclude: i64) -> Option<(f64, f64)> {
    let size = values.len() as i64;
    let (mut count, mut sum, mut sum_sq) = (0usize, 0.0f64, 0.0f64);
    for lag in lags {
        if (lag - peak_lag).abs() <= exclude || size == 0 {
            continue;
        }
        let v = f64::from(values[lag.rem_euclid(size) as usize]);
        count += 1;
        sum += v;
        sum_sq += v * v;
    }
    if count < 8 {
        return None;
    }
    let mean = sum / count as f64;
    let variance = (sum_sq / count as f64 - mean * mean).max(0.0);
    Some((mean, variance.sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_correlation_finds_a_shift_and_its_sign() {
        let a: Vec<f32> = (0..64).map(|i| ((i * 37 % 11) as f32 - 5.0) * if i < 40 { 1.0 } else { 0.0 }).collect();
        // b[i + 5] = a[i]: b lags a by 5 samples.
        let mut b = vec![0.0f32; 64];
        b[5..].copy_from_slice(&a[..59]);
        let mut work = FftWork::new();
        let c = work.cross_correlation(&a, &b, 128, Weighting::Plain);
        let best = (0..128).max_by(|&i, &j| c[i].total_cmp(&c[j])).unwrap_or(0);
        assert_eq!(best, 5);
        let direct: f32 = (0..59).map(|i| a[i] * b[i + 5]).sum();
        assert!((c[5] - direct).abs() < 1e-3 * direct.abs().max(1.0), "{} vs {direct}", c[5]);
        let backwards = work.cross_correlation(&b, &a, 128, Weighting::Plain);
        let best = (0..128).max_by(|&i, &j| backwards[i].total_cmp(&backwards[j])).unwrap_or(0);
        assert_eq!(best, 128 - 5);
    }

    #[test]
    fn parabola_peak_is_exact_for_a_parabola() {
        let f = |x: f64| 3.0 - (x - 0.3) * (x - 0.3);
        assert!((parabolic_peak_offset(f(-1.0), f(0.0), f(1.0)) - 0.3).abs() < 1e-12);
        assert_eq!(parabolic_peak_offset(1.0, 1.0, 1.0), 0.0);
    }
}
