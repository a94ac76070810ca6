//! Image quality measures: PSNR, SSIM, and a flicker measure for sequences.
//!
//! All work on colors in `[0, 1]`; a mask (when given) selects the pixels that count.

use crate::raster::{RgbRaster, ScalarRaster};

/// PSNR in dB between two color images over all pixels and channels (peak 1). Identical
/// images give `f64::INFINITY`.
pub fn psnr(a: &RgbRaster, b: &RgbRaster) -> f64 {
    psnr_masked(a, b, None)
}

/// PSNR over the pixels where `mask > 0` (all pixels without a mask).
pub fn psnr_masked(a: &RgbRaster, b: &RgbRaster, mask: Option<&ScalarRaster>) -> f64 {
    let mse = mse_masked(a, b, mask);
    if mse == 0.0 { f64::INFINITY } else { -10.0 * mse.log10() }
}

/// Mean squared error over the channels of the pixels where `mask > 0` (all pixels without a
/// mask; 0 where none counts).
pub fn mse_masked(a: &RgbRaster, b: &RgbRaster, mask: Option<&ScalarRaster>) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height), "psnr of images of different sizes");
    let mut sum = 0.0f64;
    let mut count = 0usize;
    for i in 0..a.data.len() {
        if mask.is_some_and(|m| m.data[i] <= 0.0) {
            continue;
        }
        for k in 0..3 {
            sum += f64::from(a.data[i][k] - b.data[i][k]).powi(2);
        }
        count += 3;
    }
    sum / count.max(1) as f64
}

const SSIM_C1: f64 = 0.01 * 0.01;
const SSIM_C2: f64 = 0.03 * 0.03;
const SSIM_RADIUS: usize = 5;
const SSIM_SIGMA: f64 = 1.5;

fn gaussian_kernel() -> Vec<f64> {
    let k: Vec<f64> = (0..=2 * SSIM_RADIUS)
        .map(|i| {
            let d = i as f64 - SSIM_RADIUS as f64;
            (-d * d / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp()
        })
        .collect();
    let s: f64 = k.iter().sum();
    k.into_iter().map(|v| v / s).collect()
}

/// Separable Gaussian blur with the 11-tap window, clamped at the borders: rows, then columns.
fn blur(values: &[f64], w: usize, h: usize, kernel: &[f64]) -> Vec<f64> {
    let rows = blur_1d(values, w, h, kernel, true);
    blur_1d(&rows, w, h, kernel, false)
}

/// One pass of [`blur`]: along x (`along_x`) or along y, clamped at the borders.
fn blur_1d(values: &[f64], w: usize, h: usize, kernel: &[f64], along_x: bool) -> Vec<f64> {
    let r = SSIM_RADIUS as isize;
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (k, kv) in kernel.iter().enumerate() {
                let offset = k as isize - r;
                let at = if along_x {
                    y * w + (x as isize + offset).clamp(0, w as isize - 1) as usize
                } else {
                    (y as isize + offset).clamp(0, h as isize - 1) as usize * w + x
                };
                s += kv * values[at];
            }
            out[y * w + x] = s;
        }
    }
    out
}

/// Mean SSIM (Wang et al. 2004: 11x11 Gaussian window, sigma 1.5, K1 0.01, K2 0.03, peak 1),
/// computed per channel and averaged over the three.
pub fn ssim(a: &RgbRaster, b: &RgbRaster) -> f64 {
    ssim_mean(&ssim_map(a, b))
}

/// The mean SSIM of an [`ssim_map`] (what [`ssim`] gives for the two images); 0 for no pixel.
pub fn ssim_mean(map: &[f64]) -> f64 {
    map.iter().sum::<f64>() / map.len().max(1) as f64
}

/// SSIM per pixel (row-major; the mean over the three channels of each channel's SSIM at the
/// window centred there, as [`ssim`]): its mean over some pixels is SSIM over a region.
pub fn ssim_map(a: &RgbRaster, b: &RgbRaster) -> Vec<f64> {
    assert_eq!((a.width, a.height), (b.width, b.height), "ssim of images of different sizes");
    let (w, h) = (a.width, a.height);
    let kernel = gaussian_kernel();
    let mut map = vec![0.0; w * h];
    for k in 0..3 {
        let x: Vec<f64> = a.data.iter().map(|p| f64::from(p[k])).collect();
        let y: Vec<f64> = b.data.iter().map(|p| f64::from(p[k])).collect();
        let xx: Vec<f64> = x.iter().map(|v| v * v).collect();
        let yy: Vec<f64> = y.iter().map(|v| v * v).collect();
        let xy: Vec<f64> = x.iter().zip(&y).map(|(p, q)| p * q).collect();
        let (mx, my) = (blur(&x, w, h, &kernel), blur(&y, w, h, &kernel));
        let (sxx, syy, sxy) = (blur(&xx, w, h, &kernel), blur(&yy, w, h, &kernel), blur(&xy, w, h, &kernel));
        for (i, m) in map.iter_mut().enumerate() {
            let (vx, vy, cov) = (sxx[i] - mx[i] * mx[i], syy[i] - my[i] * my[i], sxy[i] - mx[i] * my[i]);
            *m += ((2.0 * mx[i] * my[i] + SSIM_C1) * (2.0 * cov + SSIM_C2))
                / ((mx[i] * mx[i] + my[i] * my[i] + SSIM_C1) * (vx + vy + SSIM_C2))
                / 3.0;
        }
    }
    map
}

/// Per-pixel threshold on the ground truth's frame-to-frame change (mean over RGB) below which a
/// pixel counts as unchanged: 2 code values.
pub const UNCHANGED_THRESHOLD: f32 = 2.0 / 255.0;

/// Flicker of a rendered sequence against its ground truth: the mean absolute frame-to-frame
/// change of the output (mean over RGB) on pixels whose ground truth does not change (by less
/// than [`UNCHANGED_THRESHOLD`]), minus the same mean for the ground truth. 0 means no flicker
/// beyond the truth's own; returns `None` when fewer than two frames or no unchanged pixel.
pub fn flicker(output: &[RgbRaster], truth: &[RgbRaster]) -> Option<f64> {
    assert_eq!(output.len(), truth.len(), "flicker of sequences of different lengths");
    let mut sum = FlickerSum::default();
    for t in 1..output.len() {
        sum.add(&output[t - 1], &output[t], &truth[t - 1], &truth[t]);
    }
    sum.value()
}

/// [`flicker`] summed one frame pair at a time, for sequences too long to keep in memory.
#[derive(Clone, Debug, Default)]
pub struct FlickerSum {
    out_sum: f64,
    truth_sum: f64,
    count: usize,
}

impl FlickerSum {
    /// Adds the change from frame `t - 1` to frame `t` of the output and of the truth.
    pub fn add(&mut self, output_before: &RgbRaster, output: &RgbRaster, truth_before: &RgbRaster, truth: &RgbRaster) {
        assert_eq!(output.data.len(), truth.data.len(), "flicker of images of different sizes");
        for i in 0..truth.data.len() {
            let dt = mean_abs_diff(truth.data[i], truth_before.data[i]);
            if dt < UNCHANGED_THRESHOLD {
                self.out_sum += f64::from(mean_abs_diff(output.data[i], output_before.data[i]));
                self.truth_sum += f64::from(dt);
                self.count += 1;
            }
        }
    }

    /// The flicker of the pairs added so far (`None` before any unchanged pixel).
    pub fn value(&self) -> Option<f64> {
        (self.count > 0).then(|| (self.out_sum - self.truth_sum) / self.count as f64)
    }
}

fn mean_abs_diff(a: [f32; 3], b: [f32; 3]) -> f32 {
    ((a[0] - b[0]).abs() + (a[1] - b[1]).abs() + (a[2] - b[2]).abs()) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: usize, h: usize) -> RgbRaster {
        RgbRaster::from_vec(w, h, (0..w * h).map(|i| [(i % w) as f32 / w as f32, (i / w) as f32 / h as f32, 0.3]).collect()).unwrap()
    }

    #[test]
    fn psnr_known_values() {
        let a = RgbRaster::filled(4, 4, [0.5; 3]);
        assert_eq!(psnr(&a, &a), f64::INFINITY);
        // Uniform error 0.1 -> MSE 0.01 -> 20 dB.
        let b = RgbRaster::filled(4, 4, [0.6; 3]);
        assert!((psnr(&a, &b) - 20.0).abs() < 1e-5);
        // Error on one channel only: MSE 0.01 / 3.
        let c = RgbRaster::filled(4, 4, [0.6, 0.5, 0.5]);
        assert!((psnr(&a, &c) - (20.0 + 10.0 * 3f64.log10())).abs() < 1e-5);
        let mut mask = ScalarRaster::filled(4, 4, 0.0);
        mask.data[0] = 1.0;
        assert!((psnr_masked(&a, &b, Some(&mask)) - 20.0).abs() < 1e-5);
    }

    #[test]
    fn the_error_is_the_mean_over_pixels_and_channels() {
        let truth = RgbRaster::filled(2, 1, [0.5; 3]);
        let shown = RgbRaster::from_vec(2, 1, vec![[0.5; 3], [1.0, 0.5, 0.5]]).unwrap();
        assert!((mse_masked(&shown, &truth, None) - 0.25 / 6.0).abs() < 1e-9);
        assert_eq!(mse_masked(&truth, &truth, None), 0.0);
    }

    #[test]
    fn ssim_known_values() {
        let a = gradient(32, 24);
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
        // A constant offset of 0.1 on a smooth image: structure and contrast equal, luminance
        // term (2 mx my + C1) / (mx^2 + my^2 + C1) < 1.
        let b = a.map(|p| [p[0] + 0.1, p[1] + 0.1, p[2] + 0.1]);
        let s = ssim(&a, &b);
        assert!(s < 0.99 && s > 0.8, "{s}");
        // Flat gray against the same image: luminance for channel 2 = exactly
        // ((2*0.3*0.4 + C1)/(0.09 + 0.16 + C1)) with no variance.
        let flat_a = RgbRaster::filled(16, 16, [0.3; 3]);
        let flat_b = RgbRaster::filled(16, 16, [0.4; 3]);
        let expected = (2.0 * 0.3 * 0.4 + SSIM_C1) / (0.09 + 0.16 + SSIM_C1);
        assert!((ssim(&flat_a, &flat_b) - expected).abs() < 1e-6);
        // Noise lowers SSIM more than a slight blur-free shift of brightness.
        let mut noisy = a.clone();
        let mut seed = 3u32;
        for p in &mut noisy.data {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            let n = (seed >> 8) as f32 / (1 << 24) as f32 - 0.5;
            *p = [p[0] + 0.2 * n, p[1] + 0.2 * n, p[2] + 0.2 * n];
        }
        assert!(ssim(&a, &noisy) < s);
    }

    #[test]
    fn flicker_known_values() {
        let still = RgbRaster::filled(2, 1, [0.5; 3]);
        let truth = vec![still.clone(), still.clone(), still.clone()];
        assert_eq!(flicker(&truth, &truth), Some(0.0));
        // Output alternating by 0.1 on every pixel: mean change 0.1.
        let bright = RgbRaster::filled(2, 1, [0.6; 3]);
        let out = vec![still.clone(), bright, still.clone()];
        assert!((flicker(&out, &truth).unwrap() - 0.1).abs() < 1e-6);
        // Pixels where the truth changes do not count.
        let moving = RgbRaster::from_vec(2, 1, vec![[0.5; 3], [0.9; 3]]).unwrap();
        let truth2 = vec![still.clone(), moving];
        let out2 = vec![still.clone(), RgbRaster::from_vec(2, 1, vec![[0.5; 3], [0.0; 3]]).unwrap()];
        assert_eq!(flicker(&out2, &truth2), Some(0.0));
        assert_eq!(flicker(&out2[..1], &truth2[..1]), None);
    }
}
