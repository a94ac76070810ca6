//! `RenderParams`: every parameter of the renderer, with the paper's defaults.

use serde::{Deserialize, Serialize};

use crate::view_ranking::RankTolerance;

/// What to render: the full method, or one of the baselines and ablations it is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// (a) The sparse points splatted with a z-test, holes filled by push-pull.
    Splat,
    /// (b) The single best-ranked view warped with the push-pull-filled sparse depth.
    BestView,
    /// (c) A visibility-tested blend of the ranked views on push-pull-filled depth; no
    /// optimisation.
    Blend,
    /// (d) The full method without the temporal terms.
    NoTemporal,
    /// (e) The full method (paper Section 3.2-3.4).
    #[default]
    Full,
}

impl Method {
    /// All methods in the order of the comparison table.
    pub const ALL: [Method; 5] = [Method::Splat, Method::BestView, Method::Blend, Method::NoTemporal, Method::Full];

    /// Short label used in tables and on the command line.
    pub fn label(self) -> &'static str {
        match self {
            Self::Splat => "splat",
            Self::BestView => "best-view",
            Self::Blend => "blend",
            Self::NoTemporal => "no-temporal",
            Self::Full => "full",
        }
    }

    /// True for the variational methods (d) and (e).
    pub fn is_variational(self) -> bool {
        matches!(self, Self::NoTemporal | Self::Full)
    }
}

/// Every parameter of the renderer. CPU, GPU, command line and page all use this one struct.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderParams {
    /// Which method to run.
    pub method: Method,
    /// `sigma`: color tolerance of the Gaussian weights of the views, the points and the
    /// previous frame (paper Eqs. wP, wH, wT; the paper's 0.075).
    pub sigma: f32,
    /// `sigma` of the view ranking `r_F` (paper Eq. rF; the paper's 0.075, ours 0.3): how fast
    /// a view's score falls with the angle between its orientation and the virtual camera's.
    /// The score weighs the views in the colour initial guess and in the rank preference
    /// (`view_rank_exponent`). The paper has one `sigma` for colours and angles; ours keeps them
    /// apart. At 0.075 a view 10 degrees from the best one keeps under 1% of its score, so the
    /// views of a real arc (neighbours 5-30 degrees apart) all follow the best one; at 0.3 it
    /// keeps 73%. Measured in `docs/results/view_ranking.md`.
    pub rank_sigma: f32,
    /// The view ranking's cap (ours), degrees: a chosen view turned more than this beyond the
    /// best view's angle to the virtual camera keeps only the smallest weight in the colour
    /// initial guess and the rank preference, however wide `rank_sigma` is: it sees other
    /// sides of the scene and counts only where no nearer view sees. 180 is no cap; the
    /// default 45 keeps a wide-baseline rig's views (Pose2Sim's, 54 degrees or more beyond
    /// the best) out as the paper's tolerance did, and every view an arc's held-out camera
    /// chooses in. Measured in `docs/results/view_ranking.md`.
    pub rank_max_extra_angle_deg: f32,
    /// `lambda_PC`: attachment of the depth to the sparse points (paper Eq. rendering_depth;
    /// 0.25 to 2, default 1).
    pub lambda_pc: f32,
    /// `lambda_T`: temporal consistency of depth and color (paper Eqs.
    /// depth_temporalconsistency and color_temporalconsistency; 0.01 to 0.1). Default 0.1, the
    /// upper end: with `w_T` from each level's fresh estimate and coverage scaling it removes 38%
    /// of the flicker for 0.13 dB on the synthetic event; 0.05 removes 29% for 0.08 dB.
    pub lambda_t: f32,
    /// Scale `lambda_T` by the share of pixels covered by sparse points (ours). The attachment
    /// term acts only where a point lands, the temporal term on every pixel, so their balance
    /// is `lambda_PC * coverage : lambda_T`; the paper renders densified clouds (coverage near
    /// 1). Without this, sparse clouds (2% coverage) let the temporal term outweigh the points
    /// fifty-fold and depth lags behind moving objects.
    pub temporal_coverage_scaling: bool,
    /// `lambda_plane`: pull of the depth toward one plane fitted to the step's points as the
    /// virtual camera sees them (ours; 0 turns it off; see `render::plane`). It acts only where
    /// points are scarce (`plane_support`): there the membrane of the depth energy makes a bump
    /// at each point that relaxes to a mean in between, and the warped views swirl; the plane
    /// lets that depth settle on the dominant surface instead. Measured in
    /// `docs/results/real_findings.md`.
    pub lambda_plane: f32,
    /// Share of the pixels around a pixel (radius 16 px at the finest level, halved per level)
    /// carrying a point at which the plane's pull is gone (ours); below it the pull fades in
    /// linearly. 0.002 is about two points in the finest window. Larger values help the sparse
    /// real captures and hurt the synthetic event (0.01: Pose2Sim SSIM +0.012, synthetic -1.3 dB).
    pub plane_support: f32,
    /// Radius in pixels, at every pyramid level, over which each projected point attaches the
    /// depth (ours; 0 = one pixel, as the paper): a pixel without a point takes the nearest
    /// point within it. A point held at a single pixel is a spike in the membrane of the depth
    /// energy; over a patch it carries its depth to its neighbours. See `docs/RENDERER.md`.
    pub sparse_footprint_px: usize,
    /// Radius in pixels (at the finest level, halved per level) by which the step's own points
    /// nearer than the static scene are grown into the region where views keep their frames
    /// (ours, issue 33; 0 = no background plates). Elsewhere the novel pixel shows the static
    /// scene, and each view that has a background plate gives the plate's color there rather
    /// than its frame's, so that something standing in front of the static scene in one view
    /// (and out of the novel view) is not painted onto it. Needs a package with plates and a
    /// static cloud; CPU and GPU alike. See `docs/RENDERER.md`.
    pub plate_moving_dilation_px: usize,
    /// Radius in pixels (at the finest level) over which the plates' static mask fades from the
    /// region that keeps the frames to the static scene (ours; 0 = a hard edge): the mask is
    /// box-filtered, and a view with a plate mixes its frame's and its plate's colour by the
    /// mask's value, so no seam runs around the people. CPU and GPU alike. Default 3: on both
    /// Panoptic arcs and Pose2Sim every held-out camera but one (-0.01 dB) gains a little
    /// (`docs/results/static_scene.md`).
    pub plate_feather_px: usize,
    /// Radius in pixels (at the finest level) within which a pixel of the plates' static mask
    /// without a static point within the footprint takes the farthest static depth around as
    /// the static surface an own point there is compared with (ours; at or below
    /// `sparse_footprint_px`, the default 0 among them, nothing changes). The static cloud has
    /// holes (plain walls), and an own point on the wall seen through one counts as standing in
    /// front of the static scene and keeps the frames around it; the farthest rather than the
    /// nearest, so that a person in such a hole is not compared with the floor in front of his
    /// feet. Not the default (`docs/results/moving.md`). CPU and GPU alike.
    pub plate_static_reach_px: usize,
    /// `lambda_P`: color data term per view (paper Eq. rendering_color; 5 to 20, default 10).
    pub lambda_p: f32,
    /// Exponent `gamma` of the view's rank in the color energy where no point supports the
    /// depth (ours; 0 = every view alike, as the paper). There view `s`'s data and gradient
    /// terms are scaled by `(r_F^s / r_F^best)^gamma`: with depth unsure, a view far from the
    /// virtual camera lands in the wrong place, and averaging it with the best view doubles
    /// what they show; the color follows the best-ranked view instead. Where points are dense
    /// (`view_rank_support`) every view counts alike, as the paper. Measured in
    /// `docs/results/real_findings.md`.
    pub view_rank_exponent: f32,
    /// Share of the pixels around a pixel (the window of `plane_support`) carrying a point at
    /// which the rank preference of `view_rank_exponent` is gone (ours); below it the
    /// preference fades in linearly.
    pub view_rank_support: f32,
    /// `lambda_G`: color gradient term per view (paper Eq. rendering_color; 5 to 20, default 10).
    pub lambda_g: f32,
    /// `n`: number of best-ranked input views used (paper Eq. rF; 4).
    pub views: usize,
    /// The temporal terms apply at this many of the finest pyramid levels (ours; the paper does
    /// not say). At coarse levels colors are so smooth that `w_T` stays near 1 even where things
    /// move, the coarse depth sticks to the previous frame and the error accumulates from frame
    /// to frame: with temporal terms at all 4 levels the synthetic event loses 1.6 dB; at the
    /// finest level alone it loses 0.05 dB and still removes two thirds of the flicker.
    pub temporal_levels: usize,
    /// Pyramid levels; the coarsest has `1 / 4^(levels - 1)` of the pixels (paper Section 3.4:
    /// 4 levels, coarsest 1/64).
    pub levels: usize,
    /// Outer iterations {weights, depth solve, weights, color solve} per coarse level.
    pub outer_iterations: usize,
    /// Outer iterations at the finest level. One is enough: it starts from the upsampled
    /// solution, and more re-weight `w_P` against an ever smoother color (on the synthetic
    /// event 3/2 iterations gave 29.4 dB at 0.8 s, 2/1 gives 29.7 dB at 0.5 s).
    pub outer_iterations_finest: usize,
    /// Red-black sweeps per depth solve.
    pub depth_sweeps: usize,
    /// Red-black sweeps per color solve.
    pub color_sweeps: usize,
    /// Over-relaxation factor of the sweeps (1 = Gauss-Seidel; any value in (0, 2) decreases
    /// the energy monotonically).
    pub relaxation: f32,
    /// Unit of the color gradient in `w_D`: colors are multiplied by this before `||grad I||^2`.
    /// 255 measures gradients in 8-bit code values. With gradients of `[0, 1]` colors, `w_D`
    /// reaches about 1000 in flat regions and outweighs the paper's `lambda_PC` (0.25 to 2) so
    /// far that the depth turns into a stiff membrane (8% median depth error on the synthetic
    /// event); in code values the two terms balance as the paper's ranges suggest.
    pub gradient_unit: f32,
    /// `eps_g` in `w_D`, in squared gradient units: added to `||grad I||^2` so flat regions do
    /// not divide by zero (ours; the paper's Eq. wD has none).
    pub eps_gradient: f32,
    /// `eps_v` in `w_D`: added to `sum sigma_vis` so unseen pixels do not divide by zero (ours).
    pub eps_visibility: f32,
    /// Lower clamp of `w_D`, keeping the depth system well conditioned.
    pub w_d_min: f32,
    /// Upper clamp of `w_D`.
    pub w_d_max: f32,
    /// Relative depth tolerance of the visibility test `sigma_vis`.
    pub visibility_tolerance: f32,
    /// Relative depth gap of the sparse-map consistency filter (ours; 0 turns it off): a
    /// projected point is dropped when a point nearby is nearer by this factor (it is hidden
    /// in this view) or when it floats alone in front of its neighbours (an outlier). A sparse
    /// cloud has no surfaces to hide its points in a z-buffer, and the paper leaves occluded
    /// points to `w_H`, which cannot see them when the color estimate is built on them.
    pub sparse_consistency: f32,
    /// Radius in pixels of the consistency filter's surround test (ours; 0, the default, turns
    /// it off): a projected point with points nearer by the factor `1 + sparse_consistency` in
    /// each of its four quadrants within this radius is hidden, and a front point with a point
    /// of its depth within it is not an outlier. The filter's window is half the mean spacing
    /// of all points, a pixel where a dense static cloud is lent: without the test a sparse
    /// object in front of it is dropped as outliers and the cloud shows through its gaps
    /// (`render::surround`). 8 gives the synthetic event +1.5 dB but costs real footage, whose
    /// sparse front points are more often wrong (Panoptic cam04 -0.3 dB):
    /// `docs/results/static_scene.md`.
    pub sparse_surround_px: usize,
}

impl Default for RenderParams {
    fn default() -> Self {
        Self {
            method: Method::Full,
            sigma: 0.075,
            rank_sigma: 0.3,
            rank_max_extra_angle_deg: 45.0,
            lambda_pc: 1.0,
            lambda_t: 0.1,
            temporal_coverage_scaling: true,
            lambda_plane: 0.1,
            plane_support: 0.002,
            sparse_footprint_px: 2,
            plate_moving_dilation_px: 6,
            plate_feather_px: 3,
            plate_static_reach_px: 0,
            lambda_p: 10.0,
            view_rank_exponent: 1.0,
            view_rank_support: 0.01,
            lambda_g: 10.0,
            views: 4,
            levels: 4,
            temporal_levels: 1,
            outer_iterations: 2,
            outer_iterations_finest: 1,
            depth_sweeps: 24,
            color_sweeps: 12,
            relaxation: 1.6,
            gradient_unit: 255.0,
            eps_gradient: 1.0,
            eps_visibility: 1e-3,
            w_d_min: 1e-4,
            w_d_max: 10.0,
            visibility_tolerance: 0.02,
            sparse_consistency: 0.03,
            sparse_surround_px: 0,
        }
    }
}

/// A parameter out of range.
#[derive(Debug, thiserror::Error)]
#[error("render parameter `{field}`: {problem}")]
pub struct ParamsError {
    /// The parameter.
    pub field: &'static str,
    /// What is wrong.
    pub problem: String,
}

impl RenderParams {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<(), ParamsError> {
        let bad = |field, problem: String| Err(ParamsError { field, problem });
        for (field, v) in [
            ("sigma", self.sigma),
            ("rank_sigma", self.rank_sigma),
            ("gradient_unit", self.gradient_unit),
            ("eps_gradient", self.eps_gradient),
            ("eps_visibility", self.eps_visibility),
            ("w_d_min", self.w_d_min),
            ("visibility_tolerance", self.visibility_tolerance),
            ("plane_support", self.plane_support),
            ("view_rank_support", self.view_rank_support),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(field, format!("must be finite and positive, found {v}"));
            }
        }
        for (field, v) in [
            ("sparse_consistency", self.sparse_consistency),
            ("lambda_pc", self.lambda_pc),
            ("lambda_t", self.lambda_t),
            ("lambda_plane", self.lambda_plane),
            ("lambda_p", self.lambda_p),
            ("view_rank_exponent", self.view_rank_exponent),
            ("lambda_g", self.lambda_g),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(field, format!("must be finite and non-negative, found {v}"));
            }
        }
        if !(self.rank_max_extra_angle_deg > 0.0 && self.rank_max_extra_angle_deg <= 180.0) {
            return bad("rank_max_extra_angle_deg", format!("must be in (0, 180] degrees, found {}", self.rank_max_extra_angle_deg));
        }
        if !(self.w_d_max.is_finite() && self.w_d_max >= self.w_d_min) {
            return bad("w_d_max", format!("must be finite and at least w_d_min, found {}", self.w_d_max));
        }
        if !(self.relaxation > 0.0 && self.relaxation < 2.0) {
            return bad("relaxation", format!("must be in (0, 2), found {}", self.relaxation));
        }
        if self.temporal_levels > 8 {
            return bad("temporal_levels", format!("must be at most 8, found {}", self.temporal_levels));
        }
        if self.sparse_footprint_px > 16 {
            return bad("sparse_footprint_px", format!("must be at most 16, found {}", self.sparse_footprint_px));
        }
        if self.plate_static_reach_px > 32 {
            return bad("plate_static_reach_px", format!("must be at most 32, found {}", self.plate_static_reach_px));
        }
        if self.plate_feather_px > 32 {
            return bad("plate_feather_px", format!("must be at most 32, found {}", self.plate_feather_px));
        }
        if self.sparse_surround_px > 32 {
            return bad("sparse_surround_px", format!("must be at most 32, found {}", self.sparse_surround_px));
        }
        if self.plate_moving_dilation_px > 64 {
            return bad("plate_moving_dilation_px", format!("must be at most 64, found {}", self.plate_moving_dilation_px));
        }
        if !(1..=16).contains(&self.views) {
            return bad("views", format!("must be in 1..=16, found {}", self.views));
        }
        if !(1..=8).contains(&self.levels) {
            return bad("levels", format!("must be in 1..=8, found {}", self.levels));
        }
        for (field, v) in [
            ("outer_iterations", self.outer_iterations),
            ("outer_iterations_finest", self.outer_iterations_finest),
            ("depth_sweeps", self.depth_sweeps),
            ("color_sweeps", self.color_sweeps),
        ] {
            if v > 1000 {
                return bad(field, format!("must be at most 1000, found {v}"));
            }
        }
        Ok(())
    }

    /// The view ranking's tolerances (`rank_sigma`, `rank_max_extra_angle_deg`).
    pub fn rank_tolerance(&self) -> RankTolerance {
        RankTolerance { sigma: f64::from(self.rank_sigma), max_extra_angle_rad: f64::from(self.rank_max_extra_angle_deg).to_radians() }
    }

    /// Outer iterations at `level` (0 = finest).
    pub fn outer_iterations_at(&self, level: usize) -> usize {
        if level == 0 { self.outer_iterations_finest } else { self.outer_iterations }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_and_valid() {
        let p = RenderParams::default();
        assert_eq!((p.sigma, p.lambda_pc, p.lambda_t, p.lambda_p, p.lambda_g, p.views, p.levels), (0.075, 1.0, 0.1, 10.0, 10.0, 4, 4));
        p.validate().unwrap();
    }

    #[test]
    fn json_with_partial_fields_and_unknown_field() {
        let p: RenderParams = serde_json::from_str(r#"{"lambda_t": 0.1, "method": "blend"}"#).unwrap();
        assert_eq!(p.lambda_t, 0.1);
        assert_eq!(p.method, Method::Blend);
        assert_eq!(p.sigma, 0.075);
        assert!(serde_json::from_str::<RenderParams>(r#"{"lamda_t": 0.1}"#).is_err());
    }

    #[test]
    fn validation_names_the_parameter() {
        let p = RenderParams { relaxation: 2.0, ..RenderParams::default() };
        assert_eq!(p.validate().unwrap_err().field, "relaxation");
        let p = RenderParams { sigma: f32::NAN, ..RenderParams::default() };
        assert_eq!(p.validate().unwrap_err().field, "sigma");
        let p = RenderParams { rank_sigma: 0.0, ..RenderParams::default() };
        assert_eq!(p.validate().unwrap_err().field, "rank_sigma");
        for bad in [0.0, -1.0, 181.0, f32::NAN] {
            let p = RenderParams { rank_max_extra_angle_deg: bad, ..RenderParams::default() };
            assert_eq!(p.validate().unwrap_err().field, "rank_max_extra_angle_deg");
        }
    }
}
