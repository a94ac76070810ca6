//! Rendering one novel frame: the coarse-to-fine alternation of METHOD.md Part 2, and the
//! baselines it is compared with.

use super::job::{FrameJob, JobStep};
use super::params::RenderParams;
use super::plane::WorldPlane;
use super::pushpull;
use super::pyramid::{self, camera_at};
use super::solve::{ColorTerms, ColorView, DepthTerms};
use super::sparse::{SplatMaps, project_cloud};
use super::timing::{Stage, Stopwatch, Timings};
use super::warp::{ViewWarp, compute_visibility, warp_view};
use super::weights;
use crate::camera::Camera;
use crate::raster::{Rgb, RgbRaster, ScalarRaster};
use crate::scene::PointCloud;

/// Depth used where nothing at all is known (an empty cloud), in scene units.
pub const FALLBACK_DEPTH: f32 = 1.0;
/// Gray used where no color is known at all.
pub const FALLBACK_COLOR: Rgb = [0.5, 0.5, 0.5];

/// An input camera with its frame at every pyramid level (finest first), prepared once per
/// time step and reused for every virtual camera at that time.
#[derive(Clone, Debug)]
pub struct InputView {
    /// The camera at full resolution.
    pub camera: Camera,
    /// The frame at each level, finest first.
    pub levels: Vec<RgbRaster>,
}

impl InputView {
    /// Builds the pyramid of `image` (which must match `camera`'s size).
    pub fn new(camera: Camera, image: RgbRaster, levels: usize) -> Self {
        Self { camera, levels: pyramid::build(image, levels.max(1)) }
    }

    /// The camera and frame at `level` (the coarsest available when beyond).
    pub(super) fn at(&self, level: usize) -> (Camera, &RgbRaster) {
        let image = &self.levels[level.min(self.levels.len() - 1)];
        (camera_at(&self.camera, image.width, image.height), image)
    }
}

/// Everything known about one time step: its sparse cloud and its input views.
#[derive(Clone, Debug)]
pub struct TimeStepInputs {
    /// The sparse cloud of the time step.
    pub cloud: PointCloud,
    /// All input views at this time step (the renderer ranks and picks `params.views`).
    pub views: Vec<InputView>,
}

/// Depth and color of a render at one pyramid level.
#[derive(Clone, Debug)]
pub struct LevelSolution {
    /// Color.
    pub color: RgbRaster,
    /// z-depth.
    pub depth: ScalarRaster,
}

/// A previously rendered frame, for the temporal terms: its camera and its solution at every
/// pyramid level (finest first). Each level's temporal terms use the same level of the
/// previous frame: warping the finest previous frame into a coarse level instead picks the
/// nearest of many samples per pixel, biases depth toward the foreground at every edge, and
/// the bias accumulates over frames (1.6 dB lost on the synthetic event).
#[derive(Clone, Debug)]
pub struct PreviousFrame {
    /// Its camera (full resolution).
    pub camera: Camera,
    /// Its solution per level, finest first.
    pub levels: Vec<LevelSolution>,
    /// The plane its depth was pulled toward (kept for the next frame while it still fits).
    pub plane: Option<WorldPlane>,
}

pub(super) fn previous_camera(previous: Option<&PreviousFrame>) -> Camera {
    previous.map(|p| p.camera).unwrap_or(Camera {
        intrinsics: crate::camera::Intrinsics { fx: 1.0, fy: 1.0, cx: 0.0, cy: 0.0 },
        camera_from_world: crate::camera::Rigid3::IDENTITY,
        width_px: 1,
        height_px: 1,
    })
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Color at the requested resolution.
    pub color: RgbRaster,
    /// z-depth.
    pub depth: ScalarRaster,
    /// `sum_s w_P^s` at the finest level, as the color energy weighs the views (rank
    /// preference included): how well the views agree, the viewer's "weights" display. Zero
    /// for the non-variational baselines.
    pub view_weight: ScalarRaster,
    /// Indices of the input views used, best first.
    pub views_used: Vec<usize>,
    /// Whether the temporal terms were active.
    pub temporal_used: bool,
    /// Time per level and stage (zero without a clock).
    pub timings: Timings,
    /// The solutions of the coarser levels (level 1 first; empty for the baselines), kept for
    /// the next frame's temporal terms.
    pub coarse_levels: Vec<LevelSolution>,
    /// The plane the depth was pulled toward (`lambda_plane`), if one fitted.
    pub plane: Option<WorldPlane>,
}

impl RenderOutput {
    /// This frame as the previous frame of the next one.
    pub fn into_previous(self, camera: Camera) -> PreviousFrame {
        let mut levels = vec![LevelSolution { color: self.color, depth: self.depth }];
        levels.extend(self.coarse_levels);
        PreviousFrame { camera, levels, plane: self.plane }
    }
}

/// Errors of rendering.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A parameter is out of range.
    #[error(transparent)]
    Params(#[from] super::params::ParamsError),
    /// No input view was given.
    #[error("no input views for this time step")]
    NoViews,
    /// An input frame's size does not match its camera.
    #[error("input view {index}: frame is {width}x{height}, camera says {camera_width}x{camera_height}")]
    ViewSize {
        /// The view.
        index: usize,
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
        /// Camera width.
        camera_width: u32,
        /// Camera height.
        camera_height: u32,
    },
    /// The output camera is empty or too large.
    #[error("output size {width}x{height} is not in 1..=16384")]
    OutputSize {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
    /// The caller's level callback asked to stop.
    #[error("rendering cancelled")]
    Cancelled,
}

/// A coarse result offered to the caller after each pyramid level (progressive display).
pub struct LevelPreview<'a> {
    /// The level just finished (0 = finest).
    pub level: usize,
    /// Its color.
    pub color: &'a RgbRaster,
    /// Its depth.
    pub depth: &'a ScalarRaster,
}

/// Optional hooks of a render: a clock for timings, a per-level callback that may cancel, and
/// a trace of every linear solve (for tests and diagnostics; it costs an energy evaluation
/// per sweep).
#[derive(Default)]
pub struct RenderHooks<'a> {
    /// Milliseconds since an arbitrary origin; enables timings.
    pub clock: Option<&'a dyn Fn() -> f64>,
    /// Called after each level; returning `false` cancels the render.
    pub on_level: Option<&'a mut dyn FnMut(LevelPreview) -> bool>,
    /// When set, every solve appends its trace here.
    pub solve_traces: Option<&'a mut Vec<SolveTrace>>,
}

/// Which energy a solve minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolveKind {
    /// `E_D`, color fixed.
    Depth,
    /// `E_I`, depth fixed.
    Color,
}

/// The course of one linear solve.
#[derive(Clone, Debug)]
pub struct SolveTrace {
    /// Pyramid level.
    pub level: usize,
    /// Outer iteration at that level.
    pub iteration: usize,
    /// Depth or color.
    pub kind: SolveKind,
    /// The energy before the first sweep and after each sweep.
    pub energies: Vec<f64>,
    /// Relative residual `||b - A u|| / ||b||` after the last sweep.
    pub final_residual: f64,
}

impl SolveTrace {
    /// An empty trace of one solve (energies and residual filled in as it runs).
    pub(super) fn start(level: usize, iteration: usize, kind: SolveKind) -> Self {
        Self { level, iteration, kind, energies: Vec::new(), final_residual: f64::NAN }
    }
}

/// Per-level state of the views: warps, visibility and weights.
pub(super) struct LevelViews<'a> {
    views: Vec<(Camera, &'a RgbRaster)>,
    pub(super) warps: Vec<ViewWarp>,
    /// False once the depth changed since the warps were computed.
    fresh: bool,
}

impl<'a> LevelViews<'a> {
    pub(super) fn new(inputs: &'a TimeStepInputs, chosen: &[usize], level: usize) -> Self {
        Self { views: chosen.iter().map(|&s| inputs.views[s].at(level)).collect(), warps: Vec::new(), fresh: false }
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

pub(super) fn check_inputs(params: &RenderParams, camera: &Camera, inputs: &TimeStepInputs) -> Result<(), RenderError> {
    params.validate()?;
    if inputs.views.is_empty() {
        return Err(RenderError::NoViews);
    }
    for (index, v) in inputs.views.iter().enumerate() {
        let img = &v.levels[0];
        if (img.width, img.height) != (v.camera.width_px as usize, v.camera.height_px as usize) {
            return Err(RenderError::ViewSize {
                index,
                width: img.width,
                height: img.height,
                camera_width: v.camera.width_px,
                camera_height: v.camera.height_px,
            });
        }
    }
    let (w, h) = (camera.width_px, camera.height_px);
    if w == 0 || h == 0 || w > 16_384 || h > 16_384 {
        return Err(RenderError::OutputSize { width: w, height: h });
    }
    Ok(())
}

/// The sparse maps of the cloud in `camera`, with the consistency filter applied.
pub(super) fn sparse_maps(params: &RenderParams, cloud: &PointCloud, camera: &Camera) -> SplatMaps {
    let mut maps = project_cloud(cloud, camera);
    if params.sparse_consistency > 0.0 {
        maps.drop_inconsistent(params.sparse_consistency, None);
    }
    maps
}

/// Push-pull fills the sparse depth and color of `maps`.
pub(super) fn filled(maps: &SplatMaps) -> (ScalarRaster, RgbRaster) {
    let depth_values = maps.depth.map(|d| if d.is_finite() { d } else { 0.0 });
    (pushpull::fill(&depth_values, &maps.mask, FALLBACK_DEPTH), pushpull::fill(&maps.color, &maps.mask, FALLBACK_COLOR))
}

/// Renders the virtual `camera` at the time step of `inputs` with `params.method`. With
/// `previous` (and the full method), the temporal terms are active; without it, `w_T = 0`.
/// This runs a [`FrameJob`] to completion; `hooks.on_level` sees every level and may cancel.
pub fn render_frame(
    params: &RenderParams,
    camera: &Camera,
    inputs: &TimeStepInputs,
    previous: Option<&PreviousFrame>,
    hooks: &mut RenderHooks,
) -> Result<RenderOutput, RenderError> {
    let mut job = FrameJob::new(params.clone(), *camera, inputs, previous)?;
    loop {
        match job.step(hooks)? {
            JobStep::Level(level) => {
                if let Some(on_level) = hooks.on_level.as_mut()
                    && !on_level(job.preview(level))
                {
                    return Err(RenderError::Cancelled);
                }
            }
            JobStep::Done(output) => {
                if let Some(on_level) = hooks.on_level.as_mut()
                    && !on_level(LevelPreview { level: 0, color: &output.color, depth: &output.depth })
                {
                    return Err(RenderError::Cancelled);
                }
                return Ok(*output);
            }
        }
    }
}

/// The depth energy's terms from the current color, warps, sparse maps and previous frame.
/// `lambda_T`, scaled by the sparse coverage when `temporal_coverage_scaling` is on.
fn temporal_lambda(params: &RenderParams, sparse: &SplatMaps) -> f32 {
    if params.temporal_coverage_scaling {
        params.lambda_t * sparse.covered() as f32 / sparse.mask.data.len().max(1) as f32
    } else {
        params.lambda_t
    }
}

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
