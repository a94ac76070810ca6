//! The measures of `eval-real` beyond raw PSNR and SSIM (issue 33, item 6: evaluation that
//! cannot be tuned to one view):
//!
//! - colour-corrected PSNR and SSIM: per frame and per channel, the affine map `a * render + b`
//!   that best fits the real frame (least squares over the frame's pixels) is applied to the
//!   render first ([`color_corrected`]), so that a camera whose response differs from its
//!   neighbours' does not dominate the score (the field's convention, as gsplat's `cc_psnr`,
//!   which fits a richer colour map);
//! - static and moving regions: a pixel of a frame is moving where the real frame differs from
//!   the held-out camera's temporal median ([`temporal_median`]) by more than
//!   [`MOVING_THRESHOLD`] in some channel, dilated by [`MOVING_DILATION_PX`] ([`moving_mask`]);
//!   PSNR and SSIM are reported over each region ([`region_psnr`], [`region_ssim`]).
//!
//! [`Sums`] gathers all of them, and the flicker, for one way of showing a held-out camera.

use dynview_core::metrics::{FlickerSum, psnr, psnr_masked, ssim_map, ssim_mean};
use dynview_core::raster::{dilated, unit_from_u8};
use dynview_core::{RgbRaster, ScalarRaster};

/// A pixel is moving where the real frame differs from the temporal median by more than this in
/// some channel (colours in [0, 1]).
pub const MOVING_THRESHOLD: f32 = 0.1;
/// Moving pixels are dilated by this many pixels (a square window of side `2 r + 1`), so that
/// the edges of what moves count as moving.
pub const MOVING_DILATION_PX: usize = 4;
/// A render channel whose variance over the frame is at most this is flat: its affine fit is
/// the real frame's mean (no slope to divide by).
const FLAT_VARIANCE: f64 = 1e-12;

/// `render` with each channel mapped by the affine `a * render + b` that best fits `truth` in
/// the least-squares sense over all pixels, clamped to [0, 1]. A flat render channel maps to the
/// mean of `truth`'s channel.
pub fn color_corrected(render: &RgbRaster, truth: &RgbRaster) -> RgbRaster {
    assert_eq!((render.width, render.height), (truth.width, truth.height), "colour correction of images of different sizes");
    let n = render.data.len().max(1) as f64;
    let mut maps = [(0.0f64, 0.0f64); 3];
    for (c, map) in maps.iter_mut().enumerate() {
        let mean_render = render.data.iter().map(|p| f64::from(p[c])).sum::<f64>() / n;
        let mean_truth = truth.data.iter().map(|p| f64::from(p[c])).sum::<f64>() / n;
        let (mut variance, mut covariance) = (0.0, 0.0);
        for (r, t) in render.data.iter().zip(&truth.data) {
            let (dr, dt) = (f64::from(r[c]) - mean_render, f64::from(t[c]) - mean_truth);
            variance += dr * dr;
            covariance += dr * dt;
        }
        let (variance, covariance) = (variance / n, covariance / n);
        *map = if variance <= FLAT_VARIANCE {
            (0.0, mean_truth)
        } else {
            let slope = covariance / variance;
            (slope, mean_truth - slope * mean_render)
        };
    }
    render.map(|p| std::array::from_fn(|c| (maps[c].0 * f64::from(p[c]) + maps[c].1).clamp(0.0, 1.0) as f32))
}

/// The per-pixel, per-channel median of `frames` over time (the upper one of an even count);
/// `None` without frames or when their sizes differ.
pub fn temporal_median(frames: &[image::RgbImage]) -> Option<RgbRaster> {
    let first = frames.first()?;
    if frames.iter().any(|f| f.dimensions() != first.dimensions()) {
        return None;
    }
    let (width, height) = (first.width() as usize, first.height() as usize);
    let mut values = vec![0u8; frames.len()];
    let mut data = vec![[0.0f32; 3]; width * height];
    for (i, pixel) in data.iter_mut().enumerate() {
        for (c, value) in pixel.iter_mut().enumerate() {
            for (v, frame) in values.iter_mut().zip(frames) {
                *v = frame.as_raw()[3 * i + c];
            }
            let middle = values.len() / 2;
            *value = unit_from_u8(*values.select_nth_unstable(middle).1);
        }
    }
    RgbRaster::from_vec(width, height, data)
}

/// 1 where `truth` differs from `median` by more than `threshold` in some channel, dilated by
/// `dilation_px` (square window), 0 elsewhere.
pub fn moving_mask(truth: &RgbRaster, median: &RgbRaster, threshold: f32, dilation_px: usize) -> ScalarRaster {
    assert_eq!((truth.width, truth.height), (median.width, median.height), "moving mask of images of different sizes");
    let data =
        truth.data.iter().zip(&median.data).map(|(t, m)| if (0..3).any(|c| (t[c] - m[c]).abs() > threshold) { 1.0 } else { 0.0 }).collect();
    let mask = ScalarRaster::from_vec(truth.width, truth.height, data).expect("the sizes match");
    dilated(&mask, dilation_px)
}

/// Which pixels of a frame count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// Where the mask is 0.
    Static,
    /// Where the mask is positive.
    Moving,
}

impl Region {
    /// Whether a pixel whose moving mask is `mask` belongs to this region.
    fn holds(self, mask: f32) -> bool {
        (mask > 0.0) == (self == Region::Moving)
    }
}

/// PSNR (dB, peak 1) from the mean squared error over the pixels of `region` of `moving`;
/// `None` when the region has no pixel.
pub fn region_psnr(shown: &RgbRaster, truth: &RgbRaster, moving: &ScalarRaster, region: Region) -> Option<f64> {
    let selected = moving.map(|m| if region.holds(m) { 1.0 } else { 0.0 });
    selected.data.iter().any(|&s| s > 0.0).then(|| psnr_masked(shown, truth, Some(&selected)))
}

/// The mean of `ssim_map` (per pixel, [`ssim_map`]) over the pixels of `region` of `moving`;
/// `None` when the region has no pixel.
pub fn region_ssim(ssim_map: &[f64], moving: &ScalarRaster, region: Region) -> Option<f64> {
    assert_eq!(ssim_map.len(), moving.data.len(), "an SSIM map and a mask of different sizes");
    let (sum, count) = ssim_map
        .iter()
        .zip(&moving.data)
        .filter(|(_, m)| region.holds(**m))
        .fold((0.0, 0usize), |(sum, count), (s, _)| (sum + s, count + 1));
    (count > 0).then(|| sum / count as f64)
}

/// A running mean that skips the frames where a measure has no value.
#[derive(Clone, Copy, Debug, Default)]
struct Mean {
    sum: f64,
    count: u32,
}

impl Mean {
    fn add(&mut self, value: Option<f64>) {
        if let Some(v) = value {
            self.sum += v;
            self.count += 1;
        }
    }

    /// The mean, NaN before any value.
    fn value(self) -> f64 {
        if self.count == 0 { f64::NAN } else { self.sum / f64::from(self.count) }
    }
}

/// One measure as is and after colour correction.
#[derive(Clone, Copy, Debug, Default)]
pub struct RawAndCorrected {
    /// Of the render as it is.
    pub raw: f64,
    /// Of the colour-corrected render ([`color_corrected`]).
    pub corrected: f64,
}

/// The scores of one way of showing the held-out camera, averaged over the time steps (NaN where
/// no time step had a value: a region without pixels, or flicker of a single frame).
#[derive(Clone, Debug)]
pub struct Score {
    /// The method's or baseline's name.
    pub label: &'static str,
    /// PSNR over the whole frame, dB.
    pub psnr_db: RawAndCorrected,
    /// SSIM over the whole frame.
    pub ssim: RawAndCorrected,
    /// PSNR over the static pixels ([`Region::Static`]), dB.
    pub static_psnr_db: RawAndCorrected,
    /// PSNR over the moving pixels ([`Region::Moving`]), dB; averaged over the time steps with
    /// moving pixels.
    pub moving_psnr_db: RawAndCorrected,
    /// SSIM over the static pixels ([`region_ssim`]).
    pub static_ssim: RawAndCorrected,
    /// SSIM over the moving pixels; averaged over the time steps with moving pixels.
    pub moving_ssim: RawAndCorrected,
    /// Mean frame-to-frame change where the real frame does not change, minus the real frame's
    /// own ([`FlickerSum`]; colours in [0, 1]).
    pub flicker: f64,
}

/// Running sums of one way of showing the held-out camera.
#[derive(Default)]
pub struct Sums {
    psnr_db: [Mean; 2],
    ssim: [Mean; 2],
    static_psnr_db: [Mean; 2],
    moving_psnr_db: [Mean; 2],
    static_ssim: [Mean; 2],
    moving_ssim: [Mean; 2],
    flicker: FlickerSum,
    previous: Option<RgbRaster>,
}

impl Sums {
    /// Adds one time step: `shown` against `truth`, whose moving pixels are `moving`;
    /// `truth_before` is the previous step's real frame (for the flicker).
    pub fn add(&mut self, shown: RgbRaster, truth: &RgbRaster, truth_before: Option<&RgbRaster>, moving: &ScalarRaster) {
        let corrected = color_corrected(&shown, truth);
        for (k, image) in [&shown, &corrected].into_iter().enumerate() {
            self.psnr_db[k].add(Some(psnr(image, truth)));
            let map = ssim_map(image, truth);
            self.ssim[k].add(Some(ssim_mean(&map)));
            self.static_psnr_db[k].add(region_psnr(image, truth, moving, Region::Static));
            self.moving_psnr_db[k].add(region_psnr(image, truth, moving, Region::Moving));
            self.static_ssim[k].add(region_ssim(&map, moving, Region::Static));
            self.moving_ssim[k].add(region_ssim(&map, moving, Region::Moving));
        }
        if let (Some(before), Some(truth_before)) = (&self.previous, truth_before) {
            self.flicker.add(before, &shown, truth_before, truth);
        }
        self.previous = Some(shown);
    }

    /// The means so far, named `label`.
    pub fn score(&self, label: &'static str) -> Score {
        let pair = |m: &[Mean; 2]| RawAndCorrected { raw: m[0].value(), corrected: m[1].value() };
        Score {
            label,
            psnr_db: pair(&self.psnr_db),
            ssim: pair(&self.ssim),
            static_psnr_db: pair(&self.static_psnr_db),
            moving_psnr_db: pair(&self.moving_psnr_db),
            static_ssim: pair(&self.static_ssim),
            moving_ssim: pair(&self.moving_ssim),
            flicker: self.flicker.value().unwrap_or(f64::NAN),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_core::metrics::ssim;

    /// A textured image with different content per channel, colours within [0.1, 0.9].
    fn texture(w: usize, h: usize) -> RgbRaster {
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                [0.5 + 0.4 * (0.7 * x).sin(), 0.5 + 0.4 * (0.5 * y + 0.3 * x).cos(), 0.5 + 0.4 * (0.9 * x * y).sin()]
            })
            .collect();
        RgbRaster::from_vec(w, h, data).unwrap()
    }

    /// `image` with deterministic noise of amplitude `amplitude` added.
    fn noisy(image: &RgbRaster, amplitude: f32) -> RgbRaster {
        let mut out = image.clone();
        let mut seed = 7u32;
        for value in out.data.iter_mut().flatten() {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            *value += amplitude * ((seed >> 8) as f32 / (1 << 24) as f32 - 0.5);
        }
        out
    }

    #[test]
    fn an_affine_map_of_the_truth_per_channel_is_corrected_away() {
        let truth = texture(24, 16);
        let render = truth.map(|p| [0.5 * p[0] + 0.2, 0.8 * p[1] - 0.05, 1.1 * p[2] - 0.1]);
        assert!(psnr(&render, &truth) < 25.0);
        let corrected = color_corrected(&render, &truth);
        assert!(psnr(&corrected, &truth) > 60.0, "{}", psnr(&corrected, &truth));
        assert!(ssim(&corrected, &truth) > 0.9999);
    }

    #[test]
    fn a_constant_offset_does_not_change_the_corrected_psnr() {
        let truth = texture(24, 16);
        let render = noisy(&truth, 0.1);
        let brighter = render.map(|p| [p[0] + 0.05, p[1] + 0.05, p[2] + 0.05]);
        let (a, b) = (psnr(&color_corrected(&render, &truth), &truth), psnr(&color_corrected(&brighter, &truth), &truth));
        assert!(psnr(&brighter, &truth) < psnr(&render, &truth));
        assert!((a - b).abs() < 1e-4, "{a} {b}");
        // The fit can only help: least squares includes the identity map.
        assert!(a >= psnr(&render, &truth));
    }

    #[test]
    fn a_flat_render_channel_maps_to_the_truths_mean_without_dividing_by_zero() {
        let truth = texture(8, 8);
        let flat = RgbRaster::filled(8, 8, [0.3, 0.0, 1.0]);
        let corrected = color_corrected(&flat, &truth);
        let n = truth.data.len() as f32;
        for c in 0..3 {
            let mean = truth.data.iter().map(|p| p[c]).sum::<f32>() / n;
            assert!(corrected.data.iter().all(|p| p[c].is_finite() && (p[c] - mean).abs() < 1e-5));
        }
        // Flat truth too: the mean of the truth, exactly.
        let gray = RgbRaster::filled(8, 8, [0.5; 3]);
        assert_eq!(psnr(&color_corrected(&flat, &gray), &gray), f64::INFINITY);
        // A corrected value outside [0, 1] is clamped.
        let steep = RgbRaster::from_vec(2, 1, vec![[0.0; 3], [1.0; 3]]).unwrap();
        let render = RgbRaster::from_vec(2, 1, vec![[0.5; 3], [0.6; 3]]).unwrap();
        assert!(color_corrected(&render, &steep).data.iter().all(|p| p.iter().all(|v| (0.0..=1.0).contains(v))));
    }

    #[test]
    fn the_temporal_median_ignores_a_passing_object() {
        let background = image::RgbImage::from_pixel(4, 3, image::Rgb([100, 150, 200]));
        let mut passing = background.clone();
        passing.put_pixel(1, 1, image::Rgb([255, 0, 0]));
        let median = temporal_median(&[background.clone(), passing, background.clone()]).unwrap();
        assert_eq!(median.to_rgb8(), background);
        assert!(temporal_median(&[]).is_none());
        assert!(temporal_median(&[background, image::RgbImage::new(2, 2)]).is_none());
    }

    #[test]
    fn moving_pixels_exceed_the_threshold_in_some_channel_and_are_dilated() {
        let median = RgbRaster::filled(9, 7, [0.5; 3]);
        let mut truth = median.clone();
        truth.set(4, 3, [0.5, 0.5, 0.5 + 2.0 * MOVING_THRESHOLD]);
        // Below the threshold in every channel: static.
        truth.set(0, 0, [0.5 + 0.5 * MOVING_THRESHOLD; 3]);
        let undilated = moving_mask(&truth, &median, MOVING_THRESHOLD, 0);
        assert_eq!(undilated.data.iter().filter(|&&m| m > 0.0).count(), 1);
        assert_eq!(undilated.get(4, 3), 1.0);
        let mask = moving_mask(&truth, &median, MOVING_THRESHOLD, 2);
        for y in 0..7usize {
            for x in 0..9usize {
                let inside = x.abs_diff(4) <= 2 && y.abs_diff(3) <= 2;
                assert_eq!(mask.get(x, y) > 0.0, inside, "({x}, {y})");
            }
        }
        // Dilation stops at the border.
        truth.set(8, 6, [0.0; 3]);
        let mask = moving_mask(&truth, &median, MOVING_THRESHOLD, 1);
        assert_eq!(mask.get(7, 5), 1.0);
        assert_eq!(mask.data.iter().filter(|&&m| m > 0.0).count(), 9 + 4);
    }

    #[test]
    fn region_psnr_comes_from_the_mse_over_the_regions_pixels() {
        let truth = RgbRaster::filled(4, 1, [0.5; 3]);
        // Error 0.1 on the moving pixels, 0.01 on the static ones.
        let shown = RgbRaster::from_vec(4, 1, vec![[0.6; 3], [0.6; 3], [0.51; 3], [0.51; 3]]).unwrap();
        let moving = ScalarRaster::from_vec(4, 1, vec![1.0, 1.0, 0.0, 0.0]).unwrap();
        assert!((region_psnr(&shown, &truth, &moving, Region::Moving).unwrap() - 20.0).abs() < 1e-4);
        assert!((region_psnr(&shown, &truth, &moving, Region::Static).unwrap() - 40.0).abs() < 1e-3);
        let still = ScalarRaster::filled(4, 1, 0.0);
        assert_eq!(region_psnr(&shown, &truth, &still, Region::Moving), None);
        assert!(region_psnr(&shown, &truth, &still, Region::Static).is_some());
    }

    #[test]
    fn region_ssim_is_the_maps_mean_over_the_regions_pixels() {
        let truth = texture(40, 20);
        // Noise on the right half only: that half moves.
        let mut shown = truth.clone();
        let right = noisy(&truth, 0.8);
        for y in 0..20 {
            for x in 20..40 {
                shown.set(x, y, right.get(x, y));
            }
        }
        let moving = ScalarRaster::from_vec(40, 20, (0..800).map(|i| if i % 40 >= 20 { 1.0 } else { 0.0 }).collect()).unwrap();
        let map = ssim_map(&shown, &truth);
        let (still, moved) = (region_ssim(&map, &moving, Region::Static).unwrap(), region_ssim(&map, &moving, Region::Moving).unwrap());
        assert!(moved < 0.9 && still > moved + 0.05, "static {still}, moving {moved}");
        // The halves hold as many pixels: their mean is the whole frame's SSIM.
        assert!((0.5 * (still + moved) - ssim(&shown, &truth)).abs() < 1e-9);
        assert_eq!(region_ssim(&map, &ScalarRaster::filled(40, 20, 0.0), Region::Moving), None);
    }

    #[test]
    fn sums_average_over_the_steps_with_a_value() {
        let truth = texture(16, 12);
        let still = ScalarRaster::filled(16, 12, 0.0);
        let mut moving = still.clone();
        moving.set(3, 3, 1.0);
        let mut sums = Sums::default();
        sums.add(noisy(&truth, 0.1), &truth, None, &still);
        sums.add(noisy(&truth, 0.1), &truth, Some(&truth), &moving);
        let score = sums.score("x");
        assert_eq!(score.label, "x");
        assert!(score.psnr_db.corrected >= score.psnr_db.raw);
        assert!(score.moving_psnr_db.raw.is_finite() && score.static_psnr_db.raw.is_finite());
        assert!(score.moving_ssim.corrected.is_finite() && score.static_ssim.corrected <= 1.0);
        assert!(score.flicker.is_finite());
        assert!(Sums::default().score("empty").moving_psnr_db.raw.is_nan());
    }
}
