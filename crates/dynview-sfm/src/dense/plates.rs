//! Background plates (issue 33): for a camera that stands still, a clean image of the static
//! scene, estimated per pixel over the whole event while the frames stream through.
//!
//! A pixel's background is its *most stable* value: the colour it shows for the longest total
//! time. The per-pixel median is not: when someone stands still in front of the pixel for 40% of
//! the event and others walk past for another 30%, the median lands on a passer-by. Counting how
//! long each colour is seen does not, whatever the order of the frames.
//!
//! Exact counting would need a histogram per pixel; instead each pixel keeps
//! [`PlateOptions::modes`] colour modes (a running mean colour and the number of frames it was
//! seen), the streaming "heavy hitters" idea with colours matched within a tolerance:
//! - a new value joins the nearest mode within [`PlateOptions::tolerance_levels`] (largest
//!   channel difference, 8-bit levels) and moves its mean;
//! - otherwise it replaces the weakest mode (lowest count; among equal counts the one seen
//!   least recently) with a fresh mode of count 1. A fresh mode does not inherit the count it
//!   replaces (as Space-Saving would): inheriting would let the last of several passers-by
//!   outrank a background seen longer than each of them.
//!
//! Only the weakest mode is ever replaced, so with two modes or more the leading mode (a count
//! above every other) is never lost, and a count is never more than the frames its colour was
//! actually seen. The modes of a pixel are kept in order of recency (the one seen last first),
//! which breaks ties without storing a frame number: memory is `modes` x 16 bytes per pixel
//! (three `f32` means and a `u32` count), 48 bytes with the default 3 modes (100 MB for a
//! 1920x1080 camera), whatever the number of frames. The limit: a colour that only ever shows
//! in glimpses shorter than the stays of `modes - 1` other colours in between is replaced before
//! it can lead; more modes help there.
//!
//! Rows are updated in parallel; each pixel's update depends on that pixel alone, so the result
//! does not depend on the number of threads.

use std::path::PathBuf;

use image::RgbImage;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{SfmError, SfmResult};

/// Colour modes per pixel by default.
pub const DEFAULT_MODES: usize = 3;
/// Most colour modes per pixel [`PlateOptions::validate`] accepts.
pub const MAX_MODES: usize = 16;
/// Default [`PlateOptions::tolerance_levels`]: compression noise and flicker stay within it,
/// a person in front of the background (usually) does not.
pub const DEFAULT_TOLERANCE_LEVELS: f32 = 20.0;
/// Bytes of one colour mode: three `f32` channel means and a `u32` count.
pub const MODE_BYTES: usize = std::mem::size_of::<Mode>();
/// Channels of an RGB8 frame.
const CHANNELS: usize = 3;

/// How background plates are estimated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlateOptions {
    /// Colour modes kept per pixel (1..=[`MAX_MODES`]); memory is `modes` x [`MODE_BYTES`] per
    /// pixel. With one mode every change of colour starts over, so use at least 2.
    pub modes: usize,
    /// Largest difference in any channel, in 8-bit levels, for a value to join a mode
    /// (in `(0, 255]`).
    pub tolerance_levels: f32,
}

impl Default for PlateOptions {
    fn default() -> Self {
        Self { modes: DEFAULT_MODES, tolerance_levels: DEFAULT_TOLERANCE_LEVELS }
    }
}

impl PlateOptions {
    /// Checks ranges: `SfmError::Option` naming the option otherwise.
    pub fn validate(&self) -> SfmResult<()> {
        if !(1..=MAX_MODES).contains(&self.modes) {
            return Err(SfmError::Option { option: "plate-modes", problem: format!("must be in 1..={MAX_MODES}, found {}", self.modes) });
        }
        let t = self.tolerance_levels;
        if !(t.is_finite() && t > 0.0 && t <= 255.0) {
            return Err(SfmError::Option { option: "plate-tolerance", problem: format!("must be in (0, 255] levels, found {t}") });
        }
        Ok(())
    }
}

/// One colour mode of a pixel. A count of 0 marks an empty slot.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Mode {
    /// Mean colour of the values that joined it, 8-bit levels.
    mean: [f32; CHANNELS],
    /// Frames whose value joined it.
    count: u32,
}

/// A background plate: the most stable colour of every pixel and how sure it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Plate {
    /// The plate (each pixel its leading mode's mean, rounded).
    pub image: RgbImage,
    /// Per pixel, row-major, in `[0, 1]`: the share of the frames in which the pixel showed the
    /// plate's colour (a lower bound: frames before its mode last started are not counted).
    /// Near 1, the background was never hidden; below 0.5, it was hidden most of the time and
    /// the plate may show whatever hid it longest. 0 everywhere when no frame was pushed.
    pub confidence: Vec<f32>,
    /// Frames the plate was estimated from.
    pub frames: u64,
    /// Per pixel, row-major, the colours it showed besides the plate's: the estimator's other
    /// modes, most seen first, [`Plate::others_per_pixel`] of them per pixel (an empty slot has
    /// share 0). The plate's colour is the most stable one; where someone stood in front of the
    /// background longer than it was seen, the background is among these
    /// ([`super::plate_repair`]).
    pub others: Vec<PlateMode>,
}

/// A colour a pixel of a [`Plate`] showed, and for how long.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlateMode {
    /// The colour (mean of the values that joined it).
    pub color: [u8; 3],
    /// Share of the frames it was seen in, in `[0, 1]` (a lower bound, as the confidence).
    pub share: f32,
}

impl Plate {
    /// Other modes kept per pixel in [`Plate::others`] (0 when none are kept).
    pub fn others_per_pixel(&self) -> usize {
        self.others.len().checked_div(self.confidence.len()).unwrap_or(0)
    }

    /// The other modes of the pixel at row-major `index`, most seen first.
    pub fn others_at(&self, index: usize) -> &[PlateMode] {
        let k = self.others_per_pixel();
        self.others.get(index * k..(index + 1) * k).unwrap_or(&[])
    }
}

/// Streams frames of one still camera and estimates its [`Plate`].
#[derive(Clone, Debug)]
pub struct PlateEstimator {
    width: u32,
    height: u32,
    options: PlateOptions,
    /// `modes` per pixel, row-major, each pixel's modes most recently seen first.
    modes: Vec<Mode>,
    frames: u64,
    source: PathBuf,
}

impl PlateEstimator {
    /// An estimator for `width` x `height` RGB8 frames; errors on invalid options or an empty
    /// or too large size.
    pub fn new(width: u32, height: u32, options: PlateOptions) -> SfmResult<Self> {
        options.validate()?;
        let len = (width as usize).checked_mul(height as usize).and_then(|p| p.checked_mul(options.modes));
        let len = match len {
            Some(n) if n > 0 && n.checked_mul(MODE_BYTES).is_some_and(|b| b <= isize::MAX as usize) => n,
            _ => return Err(SfmError::Option { option: "plate-size", problem: format!("{width}x{height} px is empty or too large") }),
        };
        Ok(Self { width, height, options, modes: vec![Mode::default(); len], frames: 0, source: PathBuf::from("plate frames") })
    }

    /// Names the frames' origin (a camera's video) in errors.
    pub fn with_source(mut self, source: impl Into<PathBuf>) -> Self {
        self.source = source.into();
        self
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Bytes of the per-pixel state (the estimator's memory besides a few fields): fixed at
    /// creation, whatever the number of frames.
    pub fn state_bytes(&self) -> usize {
        self.modes.len() * MODE_BYTES
    }

    /// Adds a frame; `SfmError::Input` naming the expected and the given size if it differs.
    pub fn push(&mut self, frame: &RgbImage) -> SfmResult<()> {
        if frame.dimensions() != (self.width, self.height) {
            let (w, h) = frame.dimensions();
            return Err(self.size_error(format!("{w}x{h} px")));
        }
        self.push_rgb8(frame.as_raw())
    }

    /// Adds a frame given as row-major RGB8 bytes; `SfmError::Input` naming the expected and the
    /// given length if it differs.
    pub fn push_rgb8(&mut self, rgb: &[u8]) -> SfmResult<()> {
        let row_bytes = self.width as usize * CHANNELS;
        if rgb.len() != row_bytes * self.height as usize {
            return Err(self.size_error(format!("{} bytes", rgb.len())));
        }
        let k = self.options.modes;
        let tolerance = self.options.tolerance_levels;
        self.modes.par_chunks_mut(self.width as usize * k).zip(rgb.par_chunks(row_bytes)).for_each(|(modes, row)| {
            for (pixel, value) in modes.chunks_exact_mut(k).zip(row.chunks_exact(CHANNELS)) {
                update(pixel, [f32::from(value[0]), f32::from(value[1]), f32::from(value[2])], tolerance);
            }
        });
        self.frames += 1;
        Ok(())
    }

    /// The plate of the frames pushed so far (black, confidence 0, before the first frame).
    pub fn plate(&self) -> Plate {
        let k = self.options.modes;
        let mut image = RgbImage::new(self.width, self.height);
        let pixels = self.modes.len() / k;
        let mut confidence = vec![0.0; pixels];
        let mut others = vec![PlateMode::default(); pixels * (k - 1)];
        for (p, (modes, out)) in self.modes.chunks_exact(k).zip(image.pixels_mut()).enumerate() {
            (out.0, confidence[p]) = summary(modes, self.frames, &mut others[p * (k - 1)..(p + 1) * (k - 1)]);
        }
        Plate { image, confidence, frames: self.frames, others }
    }

    fn size_error(&self, got: String) -> SfmError {
        let (w, h) = (self.width, self.height);
        let bytes = w as usize * h as usize * CHANNELS;
        SfmError::Input {
            path: self.source.clone(),
            problem: format!("frame {} is {got}, expected {w}x{h} px RGB8 ({bytes} bytes) like the first", self.frames),
        }
    }
}

/// Index of the mode with the highest count; among equal counts the one seen most recently
/// (the first: modes are kept most recently seen first).
/// The plate of one pixel from its `values` (8-bit levels, in the order seen), as
/// [`PlateEstimator`] finds it from the same values pushed one frame at a time: the leading
/// colour and its share of the values; its other colours, most seen first, go to `others` (as
/// many as fit, `options.modes - 1` in a [`Plate`]; empty slots get share 0).
pub fn pixel_plate(values: &[[f32; CHANNELS]], options: &PlateOptions, others: &mut [PlateMode]) -> ([u8; CHANNELS], f32) {
    let mut modes = [Mode::default(); MAX_MODES];
    let modes = &mut modes[..options.modes.clamp(1, MAX_MODES)];
    for value in values {
        update(modes, *value, options.tolerance_levels);
    }
    summary(modes, values.len() as u64, others)
}

/// The plate colour of a pixel whose `modes` saw `frames` values and its share; its other
/// modes, most seen first, go to `others` (empty slots get share 0).
fn summary(modes: &[Mode], frames: u64, others: &mut [PlateMode]) -> ([u8; CHANNELS], f32) {
    let share = |count: u32| if frames > 0 { (f64::from(count) / frames as f64) as f32 } else { 0.0 };
    let color = |m: &Mode| m.mean.map(|v| v.round().clamp(0.0, 255.0) as u8);
    let lead = leading_index(modes);
    // The other modes, most seen first (a stable sort, on the stack: this runs per pixel).
    let empty = Mode::default();
    let mut rest = [&empty; MAX_MODES];
    let mut n = 0;
    for m in modes.iter().enumerate().filter(|&(i, m)| i != lead && m.count > 0).map(|(_, m)| m) {
        rest[n] = m;
        n += 1;
    }
    rest[..n].sort_by_key(|m| std::cmp::Reverse(m.count));
    others.fill(PlateMode::default());
    for (slot, m) in others.iter_mut().zip(&rest[..n]) {
        *slot = PlateMode { color: color(m), share: share(m.count) };
    }
    (color(&modes[lead]), share(modes[lead].count))
}

fn leading_index(modes: &[Mode]) -> usize {
    (0..modes.len()).fold(0, |best, i| if modes[i].count > modes[best].count { i } else { best })
}

/// Adds one value to a pixel's modes (most recently seen first; empty slots, count 0, last).
fn update(modes: &mut [Mode], value: [f32; CHANNELS], tolerance: f32) {
    let mut nearest: Option<(usize, f32)> = None;
    for (i, m) in modes.iter().enumerate().filter(|(_, m)| m.count > 0) {
        let d = (0..CHANNELS).map(|c| (m.mean[c] - value[c]).abs()).fold(0.0, f32::max);
        if d <= tolerance && nearest.is_none_or(|(_, best)| d < best) {
            nearest = Some((i, d));
        }
    }
    let i = match nearest {
        Some((i, _)) => {
            let m = &mut modes[i];
            m.count = m.count.saturating_add(1);
            let n = m.count as f32;
            for (mean, v) in m.mean.iter_mut().zip(value) {
                *mean += (v - *mean) / n;
            }
            i
        }
        None => {
            // The weakest: lowest count, the last (least recently seen) among equal counts.
            let weakest = (0..modes.len()).fold(0, |w, i| if modes[i].count <= modes[w].count { i } else { w });
            modes[weakest] = Mode { mean: value, count: 1 };
            weakest
        }
    };
    modes[..=i].rotate_right(1);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plate and confidence of a 1x1 camera shown `values` in order.
    fn one_pixel(values: &[[u8; 3]], options: PlateOptions) -> ([u8; 3], f32) {
        let mut e = PlateEstimator::new(1, 1, options).expect("estimator");
        for v in values {
            e.push_rgb8(v).expect("push");
        }
        let p = e.plate();
        (p.image.get_pixel(0, 0).0, p.confidence[0])
    }

    fn run(parts: &[([u8; 3], usize)]) -> Vec<[u8; 3]> {
        parts.iter().flat_map(|&(v, n)| std::iter::repeat_n(v, n)).collect()
    }

    const BG: [u8; 3] = [40, 90, 140];

    #[test]
    fn someone_standing_still_for_40_percent_leaves_the_background() {
        let (plate, confidence) = one_pixel(&run(&[(BG, 30), ([200, 30, 30], 40), (BG, 30)]), PlateOptions::default());
        assert_eq!(plate, BG);
        assert!((confidence - 0.6).abs() < 1e-6, "{confidence}");
        // The same with the person first: order does not matter.
        assert_eq!(one_pixel(&run(&[([200, 30, 30], 40), (BG, 60)]), PlateOptions::default()).0, BG);
    }

    #[test]
    fn most_stable_value_wins_over_the_median() {
        let values = run(&[([10; 3], 30), ([100; 3], 25), ([150; 3], 25), ([200; 3], 20)]);
        let mut sorted = values.clone();
        sorted.sort_unstable();
        assert_eq!(sorted[sorted.len() / 2], [100; 3], "the median is a passer-by");
        let (plate, confidence) = one_pixel(&values, PlateOptions::default());
        assert_eq!(plate, [10; 3]);
        assert!((confidence - 0.3).abs() < 1e-6, "{confidence}");
    }

    #[test]
    fn noise_averages_to_the_background_with_high_confidence() {
        // A fixed pseudo-random sequence in -5..=5 per channel.
        let mut state = 0x2545_f491_u32;
        let mut noise = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 24) as i32 % 11 - 5
        };
        let values: Vec<[u8; 3]> = (0..200).map(|_| BG.map(|c| (i32::from(c) + noise()) as u8)).collect();
        let (plate, confidence) = one_pixel(&values, PlateOptions::default());
        for (p, b) in plate.iter().zip(BG) {
            assert!(p.abs_diff(b) <= 2, "{plate:?} vs {BG:?}");
        }
        assert!(confidence > 0.99, "{confidence}");
    }

    #[test]
    fn confidence_is_lower_where_contested() {
        let clear = one_pixel(&run(&[(BG, 100)]), PlateOptions::default()).1;
        let contested = one_pixel(&run(&[(BG, 55), ([220; 3], 45)]), PlateOptions::default()).1;
        assert!((clear - 1.0).abs() < 1e-6, "{clear}");
        assert!(contested < 0.6 && contested < clear, "{contested}");
    }

    #[test]
    fn the_leading_mode_survives_churn() {
        // Background for 40 frames, then a new colour every frame (each 60 levels from the last
        // three): only the weakest mode is replaced, never the leading one.
        let mut values = run(&[(BG, 40)]);
        values.extend((0..60).map(|i| [(i % 4 * 60) as u8, 255, 0]));
        assert_eq!(one_pixel(&values, PlateOptions::default()).0, BG);
    }

    #[test]
    fn one_pixels_plate_is_the_estimators() {
        let values = run(&[([10; 3], 12), (BG, 30), ([200, 30, 30], 25), ([90; 3], 3)]);
        let mut e = PlateEstimator::new(1, 1, PlateOptions::default()).expect("estimator");
        values.iter().for_each(|v| e.push_rgb8(v).expect("push"));
        let plate = e.plate();
        let floats: Vec<[f32; 3]> = values.iter().map(|v| v.map(f32::from)).collect();
        let mut others = [PlateMode::default(); DEFAULT_MODES - 1];
        let (color, share) = pixel_plate(&floats, &PlateOptions::default(), &mut others);
        assert_eq!((color, share), (plate.image.get_pixel(0, 0).0, plate.confidence[0]));
        assert_eq!(color, BG);
        assert_eq!(&others[..], plate.others_at(0));
    }

    #[test]
    fn a_size_mismatch_names_both_sizes() {
        let mut e = PlateEstimator::new(4, 3, PlateOptions::default()).expect("estimator").with_source("cam2.mp4");
        let message = e.push(&RgbImage::new(3, 4)).expect_err("mismatch").to_string();
        assert!(message.contains("cam2.mp4") && message.contains("3x4") && message.contains("4x3"), "{message}");
        let message = e.push_rgb8(&[0; 5]).expect_err("mismatch").to_string();
        assert!(message.contains("5 bytes") && message.contains("36 bytes"), "{message}");
        assert_eq!(e.frames(), 0);
    }

    #[test]
    fn options_are_validated() {
        assert!(PlateOptions::default().validate().is_ok());
        for bad in [
            PlateOptions { modes: 0, ..PlateOptions::default() },
            PlateOptions { modes: MAX_MODES + 1, ..PlateOptions::default() },
            PlateOptions { tolerance_levels: 0.0, ..PlateOptions::default() },
            PlateOptions { tolerance_levels: f32::NAN, ..PlateOptions::default() },
            PlateOptions { tolerance_levels: 300.0, ..PlateOptions::default() },
        ] {
            assert!(matches!(PlateEstimator::new(2, 2, bad.clone()), Err(SfmError::Option { .. })), "{bad:?}");
        }
        assert!(matches!(PlateEstimator::new(0, 2, PlateOptions::default()), Err(SfmError::Option { .. })));
        assert!(matches!(PlateEstimator::new(u32::MAX, u32::MAX, PlateOptions::default()), Err(SfmError::Option { .. })));
    }
}
