//! The pieces of one pyramid level that the frame job assembles: the chosen views warped into
//! the level's camera, the sparse maps of the cloud and their push-pull fill, and the terms of
//! the depth and color energies.

use super::inputs::TimeStepInputs;
use super::params::RenderParams;
use super::plates;
use super::pushpull;
use super::solve::{ColorTerms, ColorView, DepthTerms};
use super::sparse::{SplatMaps, project_cloud};
use super::timing::{Stage, Stopwatch};
use super::warp::{ViewWarp, compute_visibility, warp_view};
use super::weights;
use crate::camera::Camera;
use crate::points::PointCloud;
use crate::raster::{Rgb, RgbRaster, ScalarRaster};

/// Depth used where nothing at all is known (an empty cloud), in scene units.
pub const FALLBACK_DEPTH: f32 = 1.0;
/// Gray used where no color is known at all.
pub const FALLBACK_COLOR: Rgb = [0.5, 0.5, 0.5];

/// Per-level state of the views: warps, visibility and weights.
pub(super) struct LevelViews<'a> {
    views: Vec<(Camera, &'a RgbRaster)>,
    /// Each view's background plate at this level, if it has one.
    plates: Vec<Option<&'a RgbRaster>>,
    /// The novel view's static mask ([`super::plates::static_mask`]: at its size, or smaller
    /// for a large view).
    static_mask: Option<&'a ScalarRaster>,
    /// That mask at this level's size, once known.
    level_mask: Option<ScalarRaster>,
    pub(super) warps: Vec<ViewWarp>,
    /// False once the depth changed since the warps were computed.
    fresh: bool,
}

impl<'a> LevelViews<'a> {
    /// The chosen views at `level`; where `static_mask` says a novel pixel shows the static
    /// scene, a view with a plate gives the plate's color there.
    pub(super) fn new(inputs: &'a TimeStepInputs, chosen: &[usize], level: usize, static_mask: Option<&'a ScalarRaster>) -> Self {
        Self {
            views: chosen.iter().map(|&s| inputs.views[s].at(level)).collect(),
            plates: chosen.iter().map(|&s| inputs.views[s].plate_at(level)).collect(),
            static_mask: static_mask.filter(|_| chosen.iter().any(|&s| inputs.views[s].plate.is_some())),
            level_mask: None,
            warps: Vec::new(),
            fresh: false,
        }
    }

    /// Marks the warps stale (the depth changed).
    pub(super) fn depth_changed(&mut self) {
        self.fresh = false;
    }

    /// Recomputes the warps and visibility with `depth`.
    pub(super) fn update(&mut self, camera: &Camera, depth: &ScalarRaster, params: &RenderParams, watch: &mut Stopwatch) {
        if self.fresh {
            return;
        }
        self.fresh = true;
        let views = &self.views;
        self.warps = crate::par::map_range(views.len(), |s| warp_view(camera, depth, &views[s].0, views[s].1));
        if let Some(mask) = self.static_mask {
            let level_mask = self.level_mask.get_or_insert_with(|| plates::mask_at(mask, depth.width, depth.height));
            let plates = &self.plates;
            let plate_warps = crate::par::map_range(views.len(), |s| plates[s].map(|p| warp_view(camera, depth, &views[s].0, p).color));
            for (warp, plate) in self.warps.iter_mut().zip(plate_warps) {
                let Some(plate) = plate else { continue };
                for ((color, plate), &stat) in warp.color.iter_mut().zip(plate).zip(&level_mask.data) {
                    *color = plates::mixed(*color, plate, stat);
                }
            }
        }
        watch.lap(Stage::Warp);
        let tol = params.visibility_tolerance;
        let sizes: Vec<usize> = views.iter().map(|(_, img)| img.data.len()).collect();
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            self.warps.par_iter_mut().zip(sizes).for_each(|(w, n)| compute_visibility(w, n, tol));
        }
        #[cfg(not(feature = "parallel"))]
        self.warps.iter_mut().zip(sizes).for_each(|(w, n)| compute_visibility(w, n, tol));
        watch.lap(Stage::Visibility);
    }

    /// Mean of the visible warps weighted by `view_weights` (one per view); pixels seen by no
    /// view keep `fallback`.
    pub(super) fn blend(&self, fallback: &RgbRaster, view_weights: &[f32]) -> RgbRaster {
        let mut out = fallback.clone();
        for (i, px) in out.data.iter_mut().enumerate() {
            let mut sum = [0.0f32; 3];
            let mut count = 0.0;
            for (w, &vw) in self.warps.iter().zip(view_weights) {
                if w.visibility[i] > 0.0 {
                    sum = [sum[0] + vw * w.color[i][0], sum[1] + vw * w.color[i][1], sum[2] + vw * w.color[i][2]];
                    count += vw;
                }
            }
            if count > 0.0 {
                *px = sum.map(|v| v / count);
            }
        }
        out
    }
}

/// The sparse maps of the cloud in `camera`, with the consistency filter applied.
pub(super) fn sparse_maps(params: &RenderParams, cloud: &PointCloud, camera: &Camera) -> SplatMaps {
    let mut maps = project_cloud(cloud, camera);
    if params.sparse_consistency > 0.0 {
        maps.drop_inconsistent(params.sparse_consistency, None, params.sparse_surround_px);
    }
    maps
}

/// Push-pull fills the sparse depth and color of `maps`.
pub(super) fn filled(maps: &SplatMaps) -> (ScalarRaster, RgbRaster) {
    let depth_values = maps.depth.map(|d| if d.is_finite() { d } else { 0.0 });
    (pushpull::fill(&depth_values, &maps.mask, FALLBACK_DEPTH), pushpull::fill(&maps.color, &maps.mask, FALLBACK_COLOR))
}

/// `lambda_T`, scaled by the sparse coverage when `temporal_coverage_scaling` is on.
fn temporal_lambda(params: &RenderParams, sparse: &SplatMaps) -> f32 {
    if params.temporal_coverage_scaling {
        params.lambda_t * sparse.covered() as f32 / sparse.mask.data.len().max(1) as f32
    } else {
        params.lambda_t
    }
}

/// The depth energy's terms from the current color, warps, sparse maps and previous frame.
pub(crate) fn depth_terms(
    params: &RenderParams,
    color: &RgbRaster,
    warps: &[ViewWarp],
    sparse: &SplatMaps,
    prev: Option<(&SplatMaps, &[f32])>,
    plane: Option<(Vec<f32>, Vec<f32>)>,
) -> DepthTerms {
    let n = color.data.len();
    let lambda_t = temporal_lambda(params, sparse);
    let mut sum_wp = vec![0.0f32; n];
    let mut sum_vis = vec![0.0f32; n];
    for warp in warps {
        let wp = weights::projection_weights(warp, color, params.sigma);
        for i in 0..n {
            sum_wp[i] += wp[i];
            sum_vis[i] += warp.visibility[i];
        }
    }
    let w_d = weights::depth_smoothness_weights(color, &sum_wp, &sum_vis, params);
    let w_h = weights::sparse_weights(sparse, color, params.sigma);
    let attach: Vec<f32> = w_h.iter().map(|&w| params.lambda_pc * w).collect();
    let (temporal, previous_depth) = match prev {
        Some((p, w_t)) => (w_t.iter().map(|w| lambda_t * w).collect(), p.depth.data.clone()),
        None => (vec![0.0; n], vec![0.0; n]),
    };
    let (plane_weight, plane_depth) = plane.unwrap_or_default();
    DepthTerms {
        width: color.width,
        height: color.height,
        w_d,
        attach,
        sparse_depth: sparse.depth.data.clone(),
        temporal,
        previous_depth,
        plane_weight,
        plane_depth,
    }
}

/// The color energy's terms from the warps, their weights and the previous frame.
pub(crate) fn color_terms<'a>(
    params: &RenderParams,
    warps: &'a [ViewWarp],
    w_p: &'a [Vec<f32>],
    sparse: &SplatMaps,
    prev: Option<(&SplatMaps, &[f32])>,
    width: usize,
    height: usize,
) -> ColorTerms<'a> {
    let n = width * height;
    let lambda_t = temporal_lambda(params, sparse);
    let (temporal, previous_color) = match prev {
        Some((p, w_t)) => (w_t.iter().map(|w| lambda_t * w).collect(), p.color.data.clone()),
        None => (vec![0.0; n], vec![[0.0; 3]; n]),
    };
    ColorTerms {
        width,
        height,
        views: warps.iter().zip(w_p).map(|(warp, w_p)| ColorView { warp, w_p }).collect(),
        lambda_p: params.lambda_p,
        lambda_g: params.lambda_g,
        temporal,
        previous_color,
    }
}
