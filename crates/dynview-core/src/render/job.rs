//! A frame render that advances one pyramid level per call, so that a single-threaded caller
//! (the browser's worker) can show each level as it finishes, yield to its event loop between
//! levels, and drop the job when the user has moved on. [`super::render_frame`] is this job run
//! to completion.

use std::borrow::Borrow;

use super::error::RenderError;
use super::hooks::{RenderHooks, SolveKind, SolveTrace};
use super::inputs::{TimeStepInputs, check_inputs};
use super::levels::{FALLBACK_COLOR, FALLBACK_DEPTH, LevelViews, color_terms, depth_terms, filled, sparse_maps};
use super::outputs::{LevelPreview, LevelSolution, PreviousFrame, RenderOutput, previous_camera};
use super::params::{Method, RenderParams};
use super::plane::{InverseDepthPlane, faded_weights, support_coverage};
use super::plates;
use super::pushpull;
use super::pyramid::{self, Pixel, camera_at};
use super::solve::{GridSystem, Norm};
use super::sparse::warp_frame;
use super::timing::{Stage, Stopwatch, Timings};
use super::weights;
use crate::camera::Camera;
use crate::raster::{Raster, RgbRaster, ScalarRaster};
use crate::view_ranking::{ChosenViews, choose_views};

/// What one [`FrameJob::step`] achieved.
#[derive(Debug)]
pub enum JobStep {
    /// A coarse level is done (its number); [`FrameJob::preview`] shows it.
    Level(usize),
    /// The frame is done.
    Done(Box<RenderOutput>),
}

/// One frame being rendered, coarsest level first. `I` and `P` are anything that lends the
/// time step's inputs and the previous frame (references natively, `Rc`s in the browser).
#[derive(Debug)]
pub struct FrameJob<I, P> {
    params: RenderParams,
    camera: Camera,
    inputs: I,
    /// The previous frame, kept only when the temporal terms apply (full method).
    previous: Option<P>,
    chosen: Vec<usize>,
    /// Relative rank scores of the chosen views (the color initial guess weights).
    init_weights: Vec<f32>,
    /// The plane the depth is pulled toward (`lambda_plane`), fitted once per frame.
    plane: Option<InverseDepthPlane>,
    /// Where the novel view shows the static scene, at its size or smaller (views with a background plate
    /// give its color there); `None` without static points or plates.
    static_mask: Option<ScalarRaster>,
    /// The level the next step solves; `None` once done.
    next_level: Option<usize>,
    depth: ScalarRaster,
    color: RgbRaster,
    view_weight: ScalarRaster,
    coarse_levels: Vec<LevelSolution>,
    timings: Timings,
}

impl<I: Borrow<TimeStepInputs>, P: Borrow<PreviousFrame>> FrameJob<I, P> {
    /// Checks the request and ranks the views; no pixel work yet.
    pub fn new(params: RenderParams, camera: Camera, inputs: I, previous: Option<P>) -> Result<Self, RenderError> {
        check_inputs(&params, &camera, inputs.borrow())?;
        let poses: Vec<_> = inputs.borrow().views.iter().map(|v| v.camera.camera_from_world).collect();
        let ChosenViews { indices: chosen, blend_weights: init_weights } =
            choose_views(&camera.camera_from_world, &poses, params.rank_tolerance(), params.views);
        let previous = if params.method == Method::Full { previous } else { None };
        let next_level = Some(if params.method.is_variational() { params.levels - 1 } else { 0 });
        let previous_plane = previous.as_ref().and_then(|p| p.borrow().plane);
        let plane = (params.method.is_variational() && params.lambda_plane > 0.0)
            .then(|| InverseDepthPlane::fit_points(&camera, &inputs.borrow().cloud.positions_world, previous_plane.as_ref()))
            .flatten();
        let with_plates = inputs.borrow().views.iter().any(|v| v.plate.is_some());
        let static_mask =
            with_plates.then(|| plates::static_mask(&params, &inputs.borrow().cloud, inputs.borrow().static_points, &camera)).flatten();
        Ok(Self {
            params,
            camera,
            inputs,
            previous,
            chosen,
            init_weights,
            plane,
            static_mask,
            next_level,
            depth: ScalarRaster::filled(1, 1, FALLBACK_DEPTH),
            color: RgbRaster::filled(1, 1, FALLBACK_COLOR),
            view_weight: ScalarRaster::filled(1, 1, 0.0),
            coarse_levels: Vec::new(),
            timings: Timings::default(),
        })
    }

    /// The pyramid level the next [`FrameJob::step`] solves (0 = finest), `None` when done.
    pub fn next_level(&self) -> Option<usize> {
        self.next_level
    }

    /// The solution of the level last finished (after [`JobStep::Level`]).
    pub fn preview(&self, level: usize) -> LevelPreview<'_> {
        LevelPreview { level, color: &self.color, depth: &self.depth }
    }

    /// Solves the next level. After the last one, returns the frame; stepping a finished job
    /// does no work and returns [`RenderError::Cancelled`].
    pub fn step(&mut self, hooks: &mut RenderHooks) -> Result<JobStep, RenderError> {
        let Some(level) = self.next_level else {
            return Err(RenderError::Cancelled);
        };
        let mut watch = Stopwatch::new(hooks.clock);
        if self.params.method.is_variational() {
            self.solve_level(level, hooks, &mut watch);
        } else {
            self.baseline(&mut watch);
        }
        let (w, h) = (self.color.width, self.color.height);
        self.timings.levels.push(watch.finish_level(level, w, h));
        if level > 0 {
            self.coarse_levels.insert(0, LevelSolution { color: self.color.clone(), depth: self.depth.clone() });
            self.next_level = Some(level - 1);
            return Ok(JobStep::Level(level));
        }
        self.next_level = None;
        let mut timings = std::mem::take(&mut self.timings);
        timings.total_ms = timings.levels.iter().map(|l| l.total_ms()).sum();
        let empty = || ScalarRaster::filled(1, 1, 0.0);
        Ok(JobStep::Done(Box::new(RenderOutput {
            color: std::mem::replace(&mut self.color, RgbRaster::filled(1, 1, FALLBACK_COLOR)),
            depth: std::mem::replace(&mut self.depth, empty()),
            view_weight: std::mem::replace(&mut self.view_weight, empty()),
            views_used: self.chosen.clone(),
            temporal_used: self.previous.is_some(),
            timings,
            coarse_levels: std::mem::take(&mut self.coarse_levels),
            plane: self.plane.map(|p| p.to_world(&self.camera)),
        })))
    }

    /// Baselines (a)-(c): push-pull filled sparse depth and one of three colorings.
    fn baseline(&mut self, watch: &mut Stopwatch) {
        let (params, camera, inputs) = (&self.params, &self.camera, self.inputs.borrow());
        let maps = sparse_maps(params, &inputs.cloud, camera);
        watch.lap(Stage::Sparse);
        let (depth, sparse_color) = filled(&maps);
        watch.lap(Stage::PushPull);
        let color = match params.method {
            Method::Splat => sparse_color,
            Method::BestView => {
                let mut views = LevelViews::new(inputs, &self.chosen[..1], 0, self.static_mask.as_ref());
                views.update(camera, &depth, params, watch);
                // The single view wherever it lands; push-pull of it elsewhere.
                let warp = &views.warps[0];
                let valid = Raster {
                    width: depth.width,
                    height: depth.height,
                    data: (0..depth.data.len()).map(|i| if warp.valid(i) { 1.0 } else { 0.0 }).collect(),
                };
                let values = Raster { width: depth.width, height: depth.height, data: warp.color.clone() };
                let fill = if valid.data.iter().any(|&v| v > 0.0) { pushpull::fill(&values, &valid, FALLBACK_COLOR) } else { sparse_color };
                watch.lap(Stage::PushPull);
                fill
            }
            _ => {
                let mut views = LevelViews::new(inputs, &self.chosen, 0, self.static_mask.as_ref());
                views.update(camera, &depth, params, watch);
                views.blend(&sparse_color, &vec![1.0; self.chosen.len()])
            }
        };
        self.view_weight = Raster::filled(depth.width, depth.height, 0.0);
        self.depth = depth;
        self.color = color;
    }

    /// One level of the variational method: initial guess, then the outer iterations of
    /// {weights, depth solve, weights, color solve}.
    fn solve_level(&mut self, level: usize, hooks: &mut RenderHooks, watch: &mut Stopwatch) {
        let (params, camera, inputs) = (&self.params, &self.camera, self.inputs.borrow());
        let sizes = pyramid::level_sizes(camera.width_px as usize, camera.height_px as usize, params.levels);
        let (w, h) = sizes[level];
        let cam = camera_at(camera, w, h);
        let points = sparse_maps(params, &inputs.cloud, &cam);
        // The plane pulls where points are scarce: counted before their footprints. Where they
        // are dense everywhere it pulls nowhere, and its depth is not needed.
        // Where points are scarce the color follows the best-ranked view (view_rank_exponent).
        // Both measure the points' support in the same window: counted once.
        let ranked = params.view_rank_exponent > 0.0;
        let coverage = (self.plane.is_some() || ranked).then(|| support_coverage(&points.mask, level));
        let plane = self.plane.zip(coverage.as_deref()).and_then(|(p, coverage)| {
            let weights = faded_weights(coverage, params.lambda_plane, params.plane_support);
            weights.iter().any(|&w| w > 0.0).then(|| (weights, p.depth_map(&cam)))
        });
        let rank_preferences = weights::rank_preferences(&self.init_weights, params.view_rank_exponent);
        let unsupported = coverage.as_deref().filter(|_| ranked).map(|coverage| faded_weights(coverage, 1.0, params.view_rank_support));
        let sparse = points.with_footprint(params.sparse_footprint_px);
        // The previous frame's solution at this level, warped into this level's camera.
        let previous = self.previous.as_ref().map(|p| p.borrow());
        let prev = previous
            .filter(|_| level < params.temporal_levels)
            .and_then(|p| p.levels.get(level))
            .map(|l| warp_frame(&camera_at(&previous_camera(previous), l.color.width, l.color.height), &l.depth, &l.color, &cam));
        watch.lap(Stage::Sparse);
        let mut views = LevelViews::new(inputs, &self.chosen, level, self.static_mask.as_ref());
        if level + 1 == params.levels {
            // Coarsest level: push-pull filled sparse depth, then the visibility-tested blend
            // of the warped views (push-pull filled sparse color where no view sees).
            let (d0, c0) = filled(&sparse);
            self.depth = d0;
            watch.lap(Stage::PushPull);
            views.update(&cam, &self.depth, params, watch);
            self.color = views.blend(&c0, &self.init_weights);
        } else {
            // Finer levels: upsampled depth; color re-initialised with the warped mean, the
            // upsampled color only where no view sees (an upsampled, blurred color would make
            // every sharp warp disagree with it in w_P and keep the blur).
            self.depth = pyramid::upsample(&self.depth, w, h);
            let coarse_color = pyramid::upsample(&self.color, w, h);
            watch.lap(Stage::PushPull);
            views.update(&cam, &self.depth, params, watch);
            self.color = views.blend(&coarse_color, &self.init_weights);
        }
        let (depth, color) = (&mut self.depth, &mut self.color);
        let mut scratch_d = vec![0.0f32; w * h];
        let mut scratch_c = vec![[0.0f32; 3]; w * h];
        // w_T from the fresh estimate of this level (before the temporal terms pull on it).
        let w_t: Option<Vec<f32>> = prev.as_ref().map(|p| weights::temporal_weights(p, &views.warps, params.sigma));
        let temporal = prev.as_ref().zip(w_t.as_deref());
        for iteration in 0..params.outer_iterations_at(level) {
            // Depth with color fixed.
            views.update(&cam, depth, params, watch);
            let depth_terms = depth_terms(params, color, &views.warps, &sparse, temporal, plane.clone());
            watch.lap(Stage::Weights);
            let trace = hooks.solve_traces.as_mut().map(|traces| (&mut **traces, SolveTrace::start(level, iteration, SolveKind::Depth)));
            let sweeps = Sweeps { count: params.depth_sweeps, relaxation: params.relaxation };
            solve(&depth_terms.system(), |u| depth_terms.energy(u), &mut depth.data, &mut scratch_d, sweeps, trace);
            views.depth_changed();
            watch.lap(Stage::DepthSolve);
            // Color with depth fixed.
            views.update(&cam, depth, params, watch);
            let mut w_p: Vec<Vec<f32>> = views.warps.iter().map(|wp| weights::projection_weights(wp, color, params.sigma)).collect();
            if let Some(unsupported) = &unsupported {
                weights::apply_rank_preference(&mut w_p, &rank_preferences, unsupported);
            }
            let color_terms = color_terms(params, &views.warps, &w_p, &sparse, temporal, w, h);
            watch.lap(Stage::Weights);
            let trace = hooks.solve_traces.as_mut().map(|traces| (&mut **traces, SolveTrace::start(level, iteration, SolveKind::Color)));
            let sweeps = Sweeps { count: params.color_sweeps, relaxation: params.relaxation };
            solve(&color_terms.system(), |u| color_terms.energy(u), &mut color.data, &mut scratch_c, sweeps, trace);
            watch.lap(Stage::ColorSolve);
            if level == 0 {
                let mut sum = vec![0.0f32; w * h];
                for wp in &w_p {
                    for (s, v) in sum.iter_mut().zip(wp) {
                        *s += v;
                    }
                }
                self.view_weight = Raster { width: w, height: h, data: sum };
            }
        }
    }
}

/// How many relaxation sweeps one solve makes, and their over-relaxation factor.
#[derive(Clone, Copy)]
struct Sweeps {
    count: usize,
    relaxation: f32,
}

/// Runs `sweeps` of `system` on `u`; with `trace`, records the energy before the first sweep
/// and after each, and the final residual, into the trace pushed onto the list.
fn solve<T: Pixel + Norm>(
    system: &GridSystem<T>,
    energy: impl Fn(&[T]) -> f64,
    u: &mut Vec<T>,
    scratch: &mut Vec<T>,
    sweeps: Sweeps,
    mut trace: Option<(&mut Vec<SolveTrace>, SolveTrace)>,
) {
    if let Some((_, t)) = trace.as_mut() {
        t.energies.push(energy(u));
    }
    for _ in 0..sweeps.count {
        system.sweep(u, scratch, sweeps.relaxation);
        if let Some((_, t)) = trace.as_mut() {
            t.energies.push(energy(u));
        }
    }
    if let Some((traces, mut t)) = trace {
        t.final_residual = system.relative_residual(u);
        traces.push(t);
    }
}
