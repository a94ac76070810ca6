//! How the visual hull is carved ([`HullOptions`]) and how its foregrounds are found
//! ([`ForegroundModel`]), read by the hull and by the foreground.

use serde::{Deserialize, Serialize};

use crate::error::{SfmError, SfmResult};

/// How the visual hull is carved.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HullOptions {
    /// How a camera's foreground is told from its plate ([`ForegroundModel`]).
    pub foreground_model: ForegroundModel,
    /// With [`ForegroundModel::Soft`], a pixel darker than its plate by one gain in every channel,
    /// where the plate has texture and the frame keeps it, is a shadow on the background: its
    /// colour cue is lowered (`dense::hull`'s foreground module). On by default since 2026-12-06
    /// (`docs/results/moving.md`: no capture here changes by more than 0.02 dB; it acts on hard
    /// shadows on textured ground).
    pub shadows: bool,
    /// Mean absolute RGB difference (colours in `[0, 1]`) between frame and plate above which a
    /// pixel is foreground (with [`ForegroundModel::Soft`], where its colour cue is certain).
    pub foreground_tolerance: f32,
    /// Plate confidence below which a pixel's foreground is unknown (it neither carves nor
    /// witnesses).
    pub min_plate_confidence: f32,
    /// Radius (px) of the opening that removes specks from the foreground.
    pub open_px: usize,
    /// Radius (px) of the closing, after the opening, that fills the foreground's small holes
    /// (a shirt the colour of the wall behind it).
    pub close_px: usize,
    /// Radius (px) the foreground is grown by before it carves: pixels of calibration error
    /// must not cut a thin arm off the hull.
    pub carve_dilation_px: usize,
    /// Rays per image width (one every `width / rays_across` pixels, both axes).
    pub rays_across: u32,
    /// Fewest rays a connected region of a camera's foreground gets: a small one (a ball, a
    /// hand) is sampled more finely than `rays_across` gives, down to every pixel. 0 (the
    /// default): every region on the `rays_across` grid (`dynview prep --hull-region-rays`).
    pub min_region_rays: usize,
    /// Depth samples along a ray, evenly in inverse depth.
    pub depth_samples: usize,
    /// Bisection steps refining where a ray enters the hull.
    pub refine_steps: usize,
    /// Fewest other cameras that must see a sample as foreground for it to be inside.
    pub min_witnesses: usize,
    /// Most other cameras that may see a sample as background with it still inside: one
    /// camera's hole in its foreground does not cut the object (the others' rays still carve
    /// the empty space in front of it).
    pub max_background_votes: usize,
    /// The nearest depth sampled, as a share of the median depth of the static scene in the
    /// camera.
    pub near_fraction: f64,
    /// An own point of the step in a hull point's cell, at most this share of the hull depth
    /// behind it, stands for it (the hull point is dropped).
    pub own_point_band: f64,
    /// Cells (of the ray grid) around a hull point whose own points, where they lie inside the
    /// hull on the ray's foreground, move it onto their surface; 0: the point stays where the
    /// ray enters the hull. 6 by default (`docs/results/moving.md`: every held-out camera of
    /// both Panoptic arcs gains).
    pub own_point_reach: usize,
}

impl Default for HullOptions {
    fn default() -> Self {
        Self {
            foreground_model: ForegroundModel::default(),
            shadows: true,
            foreground_tolerance: 0.15,
            min_plate_confidence: 0.5,
            open_px: 1,
            close_px: 3,
            carve_dilation_px: 1,
            rays_across: 160,
            min_region_rays: 0,
            depth_samples: 96,
            refine_steps: 6,
            min_witnesses: 3,
            max_background_votes: 0,
            near_fraction: 0.1,
            own_point_band: 0.25,
            own_point_reach: 6,
        }
    }
}

impl HullOptions {
    /// Checks the options; the error names the field.
    pub fn validate(&self) -> SfmResult<()> {
        let bad = |field: &str, problem: &str| Err(SfmError::Option { option: "hull", problem: format!("{field} {problem}") });
        if !(self.foreground_tolerance > 0.0 && self.foreground_tolerance < 1.0) {
            return bad("foreground_tolerance", "must lie in (0, 1)");
        }
        if !(0.0..=1.0).contains(&self.min_plate_confidence) {
            return bad("min_plate_confidence", "must lie in [0, 1]");
        }
        if self.open_px > 16 || self.close_px > 16 || self.carve_dilation_px > 32 {
            return bad("open_px / close_px / carve_dilation_px", "must be at most 16 / 16 / 32 px");
        }
        if !(8..=4096).contains(&self.rays_across) || !(4..=1024).contains(&self.depth_samples) || self.refine_steps > 32 {
            return bad("rays_across / depth_samples / refine_steps", "must lie in 8..=4096 / 4..=1024 / 0..=32");
        }
        if self.min_region_rays > 100_000 {
            return bad("min_region_rays", "must be at most 100000");
        }
        if self.min_witnesses == 0 {
            return bad("min_witnesses", "must be at least 1");
        }
        if !(self.near_fraction > 0.0 && self.near_fraction < 1.0) {
            return bad("near_fraction", "must lie in (0, 1)");
        }
        if !(0.0..=4.0).contains(&self.own_point_band) {
            return bad("own_point_band", "must lie in [0, 4]");
        }
        if self.own_point_reach > 16 {
            return bad("own_point_reach", "must be at most 16 cells");
        }
        Ok(())
    }
}

/// How a camera's foreground is told from its plate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ForegroundModel {
    /// Foreground where the colour differs from the plate's by more than the tolerance; every
    /// other pixel carves (the default until 2026-11-29).
    Difference,
    /// A probability per pixel from colour and texture (`dense::hull`'s foreground module); the
    /// default (`docs/results/moving.md`: both Panoptic arcs and the synthetic events gain in
    /// PSNR, the plain ball's depth error falls from 17% to 7%; the real arcs lose a little SSIM).
    #[default]
    Soft,
}

impl std::str::FromStr for ForegroundModel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "difference" => Ok(Self::Difference),
            "soft" => Ok(Self::Soft),
            other => Err(format!("unknown foreground model {other:?} (expected difference or soft)")),
        }
    }
}

impl std::fmt::Display for ForegroundModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Difference => "difference",
            Self::Soft => "soft",
        })
    }
}
