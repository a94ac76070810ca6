//! A camera's foreground at one time step: where its frame shows something other than its
//! background [plate](crate::dense::plates).
//!
//! [`ForegroundModel::Difference`] calls a pixel foreground where its colour differs from the
//! plate's by more than [`HullOptions::foreground_tolerance`]. A shirt the grey of the wall
//! behind it then breaks into holes, and a hole carves the person's middle out of every other
//! camera's hull. [`ForegroundModel::Soft`] gives each pixel a probability instead, from two
//! cues:
//! - colour: 0 below [`SOFT_FROM`], 1 at [`HullOptions::foreground_tolerance`], linear between;
//! - texture: where frame or plate has texture in the window around the pixel, how little the
//!   two windows correlate (zero-mean normalized cross-correlation of their grey values, which
//!   a change of brightness or contrast leaves alone: flicker, a camera's gain), counted only
//!   where the pixel's colour has changed at least a little ([`TEXTURE_GATE`]);
//!
//! their maximum, the colour cue first lowered where [`HullOptions::shadows`] finds a shadow (the
//! frame darker than the plate by one gain in every channel, between [`SHADOW_DARKEST`] and
//! [`SHADOW_LIGHTEST`], where the plate has texture and the frame keeps it: [`shadow_cue`]),
//! box-filtered over 3 x 3 pixels. A pixel is foreground (rays start there) where
//! the probability is at least one half, and it carves only where it is below [`CARVE_BELOW`]
//! (one half as well: a band below it that neither started rays nor carved measured no better,
//! `docs/results/moving.md`), so a pixel the opening drops carves nothing. Both models then
//! open and close the mask as [`HullOptions::open_px`] and [`HullOptions::close_px`] say.

use dynview_core::raster::{ScalarRaster, box_filtered, dilated};

use super::options::{ForegroundModel, HullOptions};
use crate::dense::plates::Plate;
use crate::dense::static_cloud::difference;
use crate::error::{SfmError, SfmResult};

/// Mean absolute RGB difference (colours in `[0, 1]`) at which the soft colour cue begins.
pub const SOFT_FROM: f32 = 0.05;
/// Radius (px) of the window the texture cue compares.
pub const TEXTURE_RADIUS_PX: usize = 3;
/// Standard deviation of the grey values (in `[0, 1]`) below which a window has no texture
/// (the texture cue is 0), and above which ([`TEXTURE_FULL`]) it counts fully.
pub const TEXTURE_FROM: f32 = 0.015;
/// See [`TEXTURE_FROM`].
pub const TEXTURE_FULL: f32 = 0.04;
/// The noise (grey standard deviation) added to both windows' variances before they are
/// correlated, so that two flat windows do not correlate by chance.
pub const TEXTURE_NOISE: f32 = 0.01;
/// Colour difference below which the texture cue does not count, and above which
/// ([`TEXTURE_GATE_FULL`]) it counts fully: a pixel that looks exactly like its plate is
/// background whatever its neighbours do (the texture window reaches past an object's edge).
pub const TEXTURE_GATE: f32 = 0.02;
/// See [`TEXTURE_GATE`].
pub const TEXTURE_GATE_FULL: f32 = 0.05;
/// The darkest a shadow makes the plate (the frame's brightness over the plate's): darker is
/// something else (dark trousers on a grey floor).
pub const SHADOW_DARKEST: f32 = 0.35;
/// The lightest a shadow leaves the plate; lighter changes are the colour cue's to judge.
pub const SHADOW_LIGHTEST: f32 = 0.95;
/// Largest difference of chromaticity (each channel's share of the pixel's sum) between frame
/// and plate at which a pixel may be in shadow; it counts fully below half of this.
pub const SHADOW_CHROMA: f32 = 0.04;
/// Correlation of the frame's window with the plate's above which the plate's texture counts as
/// kept (fully from [`SHADOW_KEPT_FULL`]).
pub const SHADOW_KEPT_FROM: f32 = 0.6;
/// See [`SHADOW_KEPT_FROM`].
pub const SHADOW_KEPT_FULL: f32 = 0.85;
/// A pixel of the soft model carves (calls the space it sees empty) only where its probability
/// is below this.
pub const CARVE_BELOW: f32 = 0.5;

/// A camera's foreground at one step: per pixel, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Foreground {
    /// How likely the pixel shows something other than the plate, in `[0, 1]` (0 or 1 with
    /// [`ForegroundModel::Difference`]; 0 where the plate is unsure).
    pub probability: ScalarRaster,
    /// 1 where the frame differs from the plate (the probability at least one half, opened and
    /// closed), else 0: rays start here.
    pub mask: ScalarRaster,
    /// 1 where the plate is too unsure to tell, else 0.
    pub unknown: ScalarRaster,
    /// What must not carve (the mask, the unknown pixels and, with the soft model, every pixel
    /// at least `CARVE_BELOW` likely), grown by [`HullOptions::carve_dilation_px`]: 0 carves.
    pub keeps: ScalarRaster,
    /// The mask and the unknown pixels alone, grown alike: 1 where the pixel surely shows
    /// something other than the plate, or may. With [`ForegroundModel::Difference`] the same
    /// as [`Self::keeps`]; with the soft model a pixel where this is 0 and `keeps` 1 is unsure.
    pub grown: ScalarRaster,
}

/// The foreground of `frame` against its camera's `plate` (same size).
pub fn foreground(frame: &image::RgbImage, plate: &Plate, options: &HullOptions) -> SfmResult<Foreground> {
    let (w, h) = (plate.image.width() as usize, plate.image.height() as usize);
    if (frame.width() as usize, frame.height() as usize) != (w, h) || plate.confidence.len() != w * h {
        return Err(SfmError::Reconstruction(format!(
            "a frame of {}x{} px does not match its plate of {w}x{h} px",
            frame.width(),
            frame.height()
        )));
    }
    let mut unknown = ScalarRaster::filled(w, h, 0.0);
    let mut colour_difference = ScalarRaster::filled(w, h, 0.0);
    for i in 0..w * h {
        if plate.confidence[i] < options.min_plate_confidence {
            unknown.data[i] = 1.0;
        } else {
            colour_difference.data[i] = difference(unit_at(frame, i), unit_at(&plate.image, i));
        }
    }
    // With the soft model, pixels too likely foreground to carve beyond the mask.
    let (probability, unsure) = match options.foreground_model {
        ForegroundModel::Difference => (colour_difference.map(|d| f32::from(u8::from(d > options.foreground_tolerance))), None),
        ForegroundModel::Soft => {
            let mut p = soft_probability(frame, plate, &colour_difference, options);
            p.data.iter_mut().zip(&unknown.data).for_each(|(p, u)| *p *= 1.0 - u);
            let unsure = p.map(|p| f32::from(u8::from(p >= CARVE_BELOW)));
            (p, Some(unsure))
        }
    };
    let raw = probability.map(|p| f32::from(u8::from(p >= 0.5)));
    let mask = closed(&opened(&raw, options.open_px), options.close_px);
    let mut sure = mask.clone();
    sure.data.iter_mut().zip(&unknown.data).for_each(|(k, u)| *k = k.max(*u));
    let grown = dilated(&sure, options.carve_dilation_px);
    let keeps = match unsure {
        None => grown.clone(),
        Some(mut unsure) => {
            unsure.data.iter_mut().zip(&sure.data).for_each(|(u, s)| *u = u.max(*s));
            dilated(&unsure, options.carve_dilation_px)
        }
    };
    Ok(Foreground { probability, mask, unknown, keeps, grown })
}

/// The colour of pixel `i` (row-major) of `image`, each channel in `[0, 1]`.
fn unit_at(image: &image::RgbImage, i: usize) -> [f32; 3] {
    let raw = &image.as_raw()[3 * i..3 * i + 3];
    [0, 1, 2].map(|c| f32::from(raw[c]) / 255.0)
}

/// `(x - from) / (to - from)`, clamped to `[0, 1]`.
fn ramp(x: f32, from: f32, to: f32) -> f32 {
    ((x - from) / (to - from)).clamp(0.0, 1.0)
}

/// The soft model's probability per pixel (the module's comment), before unsure plate pixels
/// are set to 0.
fn soft_probability(frame: &image::RgbImage, plate: &Plate, colour_difference: &ScalarRaster, options: &HullOptions) -> ScalarRaster {
    let (w, h) = (colour_difference.width, colour_difference.height);
    let tolerance = options.foreground_tolerance;
    let grey = |image: &image::RgbImage| {
        let data = image.pixels().map(|p| p.0.iter().map(|&v| f32::from(v)).sum::<f32>() / (3.0 * 255.0)).collect();
        ScalarRaster::from_vec(w, h, data).expect("an image's pixels fill its raster")
    };
    let (f, p) = (grey(frame), grey(&plate.image));
    let product = |a: &ScalarRaster, b: &ScalarRaster| {
        ScalarRaster::from_vec(w, h, a.data.iter().zip(&b.data).map(|(x, y)| x * y).collect()).expect("same size")
    };
    let r = TEXTURE_RADIUS_PX;
    let (mean_f, mean_p) = (box_filtered(&f, r), box_filtered(&p, r));
    let (ff, pp, fp) = (box_filtered(&product(&f, &f), r), box_filtered(&product(&p, &p), r), box_filtered(&product(&f, &p), r));
    let noise = TEXTURE_NOISE * TEXTURE_NOISE;
    let cues: Vec<f32> = (0..w * h)
        .map(|i| {
            let d = colour_difference.data[i];
            let mut colour = if tolerance > SOFT_FROM { ramp(d, SOFT_FROM, tolerance) } else { f32::from(u8::from(d > tolerance)) };
            let var_f = (ff.data[i] - mean_f.data[i] * mean_f.data[i]).max(0.0);
            let var_p = (pp.data[i] - mean_p.data[i] * mean_p.data[i]).max(0.0);
            let covariance = fp.data[i] - mean_f.data[i] * mean_p.data[i];
            let correlation = covariance / ((var_f + noise) * (var_p + noise)).sqrt();
            let texture = ramp(var_f.max(var_p).sqrt(), TEXTURE_FROM, TEXTURE_FULL);
            let texture_cue = ramp(1.0 - correlation, 0.5, 1.0) * texture * ramp(d, TEXTURE_GATE, TEXTURE_GATE_FULL);
            if options.shadows && colour > 0.0 {
                let plate_texture = ramp(var_p.sqrt(), TEXTURE_FROM, TEXTURE_FULL);
                colour *= 1.0 - shadow_cue(unit_at(frame, i), unit_at(&plate.image, i), correlation) * plate_texture;
            }
            colour.max(texture_cue)
        })
        .collect();
    box_filtered(&ScalarRaster::from_vec(w, h, cues).expect("one cue per pixel"), 1)
}

/// How surely a pixel of colour `frame` over a plate of colour `plate` (both in `[0, 1]`) is the
/// plate in shadow, in `[0, 1]`, given the zero-mean normalized correlation of the two windows
/// around it: darker by one gain in every channel ([`SHADOW_DARKEST`] to [`SHADOW_LIGHTEST`]),
/// the same chromaticity ([`SHADOW_CHROMA`]) and the plate's texture kept ([`SHADOW_KEPT_FROM`]).
/// The caller weighs it by how much texture the plate has: on a plain floor a shadow and a grey
/// shirt look alike.
pub fn shadow_cue(frame: [f32; 3], plate: [f32; 3], correlation: f32) -> f32 {
    let (sum_f, sum_p) = (frame.iter().sum::<f32>(), plate.iter().sum::<f32>());
    if sum_p < 0.15 || sum_f <= 0.0 {
        return 0.0;
    }
    let gain = sum_f / sum_p;
    let darker = ramp(gain, SHADOW_DARKEST, SHADOW_DARKEST + 0.1) * (1.0 - ramp(gain, SHADOW_LIGHTEST - 0.05, SHADOW_LIGHTEST));
    let chroma = (0..3).map(|c| (frame[c] / sum_f - plate[c] / sum_p).abs()).fold(0.0, f32::max);
    let same_chroma = 1.0 - ramp(chroma, SHADOW_CHROMA / 2.0, SHADOW_CHROMA);
    darker * same_chroma * ramp(correlation, SHADOW_KEPT_FROM, SHADOW_KEPT_FULL)
}

/// The minimum of a 0/1 `mask` over a square window of side `2 radius + 1`.
fn eroded(mask: &ScalarRaster, radius: usize) -> ScalarRaster {
    let mut inverse = mask.clone();
    inverse.data.iter_mut().for_each(|v| *v = 1.0 - *v);
    let mut out = dilated(&inverse, radius);
    out.data.iter_mut().for_each(|v| *v = 1.0 - *v);
    out
}

/// `mask` eroded, then dilated, by `radius`.
fn opened(mask: &ScalarRaster, radius: usize) -> ScalarRaster {
    dilated(&eroded(mask, radius), radius)
}

/// `mask` dilated, then eroded, by `radius`.
fn closed(mask: &ScalarRaster, radius: usize) -> ScalarRaster {
    eroded(&dilated(mask, radius), radius)
}
