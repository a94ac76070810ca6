//! The frame loop on the GPU: METHOD.md Part 2 level by level, as dynview-core's `FrameJob`
//! for the full method and its no-temporal ablation, every stage a compute pass.

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::Arc;

use dynview_core::camera::Camera;
use dynview_core::render::plane::{InverseDepthPlane, WorldPlane};
use dynview_core::render::pyramid::{camera_at, level_sizes};
use dynview_core::render::{FALLBACK_COLOR, FALLBACK_DEPTH, Method, RenderParams, TimeStepInputs};
use dynview_core::render::{plates, weights};
use dynview_core::view_ranking::{ChosenViews, choose_views};

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::passes::assemble::AssembleKernels;
use crate::passes::blend::BlendKernel;
use crate::passes::consistency::ConsistencyKernels;
use crate::passes::pyramid::ImageKernels;
use crate::passes::rank::RankKernels;
use crate::passes::solver::{GridSolver, SweepKernel};
use crate::passes::splat::{GpuCloud, GpuSplat, SplatKernels};
use crate::passes::static_mask::StaticMaskKernels;
use crate::passes::temporal::TemporalKernels;
use crate::passes::warp::WarpKernels;

/// A time step's inputs on the GPU: the cloud, and the pyramids of the views uploaded so far
/// (all of them with [`GpuInputs::upload`]; with [`GpuInputs::upload_cloud`] only those a frame
/// chose, by [`GpuRenderer::upload_views_for`]).
#[derive(Debug)]
pub struct GpuInputs {
    cloud: GpuCloud,
    /// The cloud's world positions, kept on the host for the plane fit (`render::plane`).
    positions_world: Vec<[f32; 3]>,
    /// Per view: its full-resolution camera and, once uploaded, its frame per level (finest
    /// first).
    views: Vec<(Camera, Option<Vec<GpuImage>>)>,
    /// Per view: its background plate per level (finest first), once the view is uploaded and
    /// if it has one (shared with other time steps' inputs where the host shares the plate).
    plates: Vec<Option<Rc<Vec<GpuImage>>>>,
    /// How many of the cloud's points (at its end) are static, for the static mask of the
    /// plates (computed on the GPU, [`StaticMaskKernels`]); `None` when no view has a plate.
    static_points: Option<usize>,
}

impl GpuInputs {
    /// Uploads `inputs`: the cloud and every view's pyramid (as built by dynview-core).
    pub fn upload(ctx: &GpuContext, inputs: &TimeStepInputs) -> Result<Self, GpuError> {
        let mut uploaded = Self::upload_cloud(ctx, inputs)?;
        for view in 0..inputs.views.len() {
            uploaded.upload_view(ctx, inputs, view, None, None)?;
        }
        Ok(uploaded)
    }

    /// Uploads the cloud of `inputs` and notes its views' cameras; their frames follow when a
    /// frame needs them ([`GpuRenderer::upload_views_for`]): a playback frame uploads the
    /// views it renders from, not every camera of the capture.
    pub fn upload_cloud(ctx: &GpuContext, inputs: &TimeStepInputs) -> Result<Self, GpuError> {
        let has_plates = inputs.views.iter().any(|v| v.plate.is_some());
        Ok(Self {
            cloud: GpuCloud::upload(ctx, &inputs.cloud)?,
            positions_world: inputs.cloud.positions_world.clone(),
            views: inputs.views.iter().map(|v| (v.camera, None)).collect(),
            plates: inputs.views.iter().map(|_| None).collect(),
            static_points: has_plates.then_some(inputs.static_points),
        })
    }

    /// The views whose frames are on the GPU, by index in the time step's inputs.
    pub fn uploaded_views(&self) -> Vec<usize> {
        self.views.iter().enumerate().filter(|(_, (_, levels))| levels.is_some()).map(|(i, _)| i).collect()
    }

    /// Uploads view `view` of `inputs` unless it is: every level, or (with `images`) the
    /// finest, its coarser levels downsampled on the GPU as dynview-core's pyramid makes them.
    /// A plate already on the GPU (`plates`, by the host pyramid it came from) is not uploaded
    /// again.
    fn upload_view(
        &mut self,
        ctx: &GpuContext,
        inputs: &TimeStepInputs,
        view: usize,
        images: Option<&ImageKernels>,
        plates: Option<&mut UploadedPlates>,
    ) -> Result<(), GpuError> {
        if self.views.len() != inputs.views.len() {
            return Err(GpuError::InvalidParams {
                field: "inputs",
                reason: format!("{} views, the uploaded time step has {}", inputs.views.len(), self.views.len()),
            });
        }
        let Some((_, levels)) = self.views.get_mut(view) else {
            return Err(GpuError::InvalidParams { field: "inputs", reason: format!("no view {view}") });
        };
        if levels.is_some() {
            return Ok(());
        }
        let source = &inputs.views[view];
        *levels = Some(upload_pyramid(ctx, &source.levels, images)?);
        self.plates[view] = match (&source.plate, plates) {
            (None, _) => None,
            (Some(host), Some(plates)) => Some(plates.get_or_upload(host, || upload_pyramid(ctx, host, images))?),
            (Some(host), None) => Some(Rc::new(upload_pyramid(ctx, host, images)?)),
        };
        Ok(())
    }
}

/// Most plates [`UploadedPlates`] keeps (cameras of an event, with room to spare).
const PLATES_KEPT: usize = 32;

/// Background plates on the GPU, by the host pyramid each came from: the inputs of every time
/// step share one pyramid per camera (`dynview_core::render::PlatePyramids`), so a plate is
/// uploaded once, not with every time step.
#[derive(Debug, Default)]
struct UploadedPlates(Vec<(HostPlate, Rc<Vec<GpuImage>>)>);

/// A plate's pyramid on the host, shared by the time steps' inputs.
type HostPlate = Arc<Vec<dynview_core::RgbRaster>>;

impl UploadedPlates {
    /// The plate uploaded from `host`, uploaded by `upload` unless it already is.
    fn get_or_upload(
        &mut self,
        host: &HostPlate,
        upload: impl FnOnce() -> Result<Vec<GpuImage>, GpuError>,
    ) -> Result<Rc<Vec<GpuImage>>, GpuError> {
        if let Some((_, plate)) = self.0.iter().find(|(h, _)| Arc::ptr_eq(h, host)) {
            return Ok(plate.clone());
        }
        let plate = Rc::new(upload()?);
        if self.0.len() >= PLATES_KEPT {
            self.0.remove(0);
        }
        self.0.push((host.clone(), plate.clone()));
        Ok(plate)
    }
}

/// `levels` (finest first) on the GPU: each uploaded, or (with `images`) the finest uploaded
/// and each coarser one downsampled from the one before on the GPU (the box filter of
/// dynview-core's `pyramid::build`, whose sizes it checks).
fn upload_pyramid(ctx: &GpuContext, levels: &[dynview_core::RgbRaster], images: Option<&ImageKernels>) -> Result<Vec<GpuImage>, GpuError> {
    let upload = |l: &dynview_core::RgbRaster| GpuImage::upload(ctx, l.data.as_flattened(), l.width, l.height, 3);
    let Some(images) = images else {
        return levels.iter().map(upload).collect();
    };
    let Some(finest) = levels.first() else {
        return Ok(Vec::new());
    };
    let mut out = vec![upload(finest)?];
    for level in &levels[1..] {
        let next = images.downsample(ctx, &out[out.len() - 1])?;
        if (next.width, next.height) != (level.width, level.height) {
            return Err(GpuError::Size(format!(
                "a pyramid level of {}x{} where the inputs have {}x{}",
                next.width, next.height, level.width, level.height
            )));
        }
        out.push(next);
    }
    Ok(out)
}

/// A rendered frame on the GPU, kept for the next frame's temporal terms.
#[derive(Debug)]
pub struct GpuFrame {
    /// Its camera (full resolution).
    pub camera: Camera,
    /// Depth (1 channel) and color (RGB) per level, finest first.
    pub levels: Vec<(GpuImage, GpuImage)>,
    /// `sum_s w_P^s` over the views used at the finest level, for the view-weights display
    /// (dynview-core's `FrameOutput::view_weight`).
    pub view_weight: Option<GpuImage>,
    /// How many views were used.
    pub views_used: usize,
    /// The plane the depth was pulled toward (kept for the next frame while it still fits).
    pub plane: Option<WorldPlane>,
}

impl GpuFrame {
    /// The finest color.
    pub fn color(&self) -> &GpuImage {
        &self.levels[0].1
    }

    /// The finest depth.
    pub fn depth(&self) -> &GpuImage {
        &self.levels[0].0
    }
}

/// Every kernel of the renderer, compiled once per device.
#[derive(Debug)]
pub struct GpuRenderer {
    solver: GridSolver,
    images: ImageKernels,
    warps: WarpKernels,
    assemble: AssembleKernels,
    splat: SplatKernels,
    consistency: ConsistencyKernels,
    blend: BlendKernel,
    temporal: TemporalKernels,
    rank: RankKernels,
    static_mask: StaticMaskKernels,
    /// Plates uploaded for earlier time steps, reused by later ones.
    plates: RefCell<UploadedPlates>,
}

impl GpuRenderer {
    /// Compiles the kernels on `ctx`'s device, the sweep kernel chosen for its adapter
    /// ([`SweepKernel::for_adapter`]).
    pub fn new(ctx: &GpuContext) -> Self {
        Self::with_sweep_kernel(ctx, SweepKernel::for_adapter(&ctx.adapter_info))
    }

    /// Compiles the kernels on `ctx`'s device with the sweep kernel `sweeps`.
    pub fn with_sweep_kernel(ctx: &GpuContext, sweeps: SweepKernel) -> Self {
        Self {
            solver: GridSolver::with_kernel(ctx, sweeps),
            images: ImageKernels::new(ctx),
            warps: WarpKernels::new(ctx),
            assemble: AssembleKernels::new(ctx),
            splat: SplatKernels::new(ctx),
            consistency: ConsistencyKernels::new(ctx),
            blend: BlendKernel::new(ctx),
            temporal: TemporalKernels::new(ctx),
            rank: RankKernels::new(ctx),
            static_mask: StaticMaskKernels::new(ctx),
            plates: Default::default(),
        }
    }

    /// The kernel that runs the red-black sweeps.
    pub fn sweep_kernel(&self) -> SweepKernel {
        self.solver.kernel()
    }

    /// The views a frame of `camera` renders from, ranked as dynview-core ranks them.
    fn views_for(params: &RenderParams, camera: &Camera, inputs: &GpuInputs) -> ChosenViews {
        let poses: Vec<_> = inputs.views.iter().map(|(c, _)| c.camera_from_world).collect();
        choose_views(&camera.camera_from_world, &poses, params.rank_tolerance(), params.views)
    }

    /// Uploads into `uploaded` the views of `inputs` (the same time step) that a frame of
    /// `camera` renders from and that are not on the GPU yet: each view's finest level, its
    /// coarser levels made on the GPU; a plate uploaded for an earlier time step (the same
    /// host pyramid: `dynview_core::render::PlatePyramids`) is reused, not uploaded again.
    pub fn upload_views_for(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        camera: &Camera,
        uploaded: &mut GpuInputs,
        inputs: &TimeStepInputs,
    ) -> Result<(), GpuError> {
        let mut plates = self.plates.borrow_mut();
        for view in Self::views_for(params, camera, uploaded).indices {
            uploaded.upload_view(ctx, inputs, view, Some(&self.images), Some(&mut plates))?;
        }
        Ok(())
    }

    /// Renders `camera` at the time step of `inputs` with the full method (temporal terms from
    /// `previous` when given) or the no-temporal ablation (`params.method`). The baselines
    /// stay on the CPU.
    pub fn render(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        camera: &Camera,
        inputs: &GpuInputs,
        previous: Option<&GpuFrame>,
    ) -> Result<GpuFrame, GpuError> {
        params.validate().map_err(|e| GpuError::InvalidParams { field: e.field, reason: e.problem })?;
        if !params.method.is_variational() {
            return Err(GpuError::InvalidParams { field: "method", reason: format!("{:?} runs on the CPU only", params.method) });
        }
        if inputs.views.is_empty() {
            return Err(GpuError::InvalidParams { field: "inputs", reason: "no input views".into() });
        }
        let previous = if params.method == Method::Full { previous } else { None };
        // The whole frame in one command buffer and one submit.
        let _frame = ctx.frame();
        let ChosenViews { indices: chosen, blend_weights } = Self::views_for(params, camera, inputs);
        if let Some(&missing) = chosen.iter().find(|&&s| inputs.views[s].1.is_none()) {
            return Err(GpuError::InvalidParams {
                field: "inputs",
                reason: format!("view {missing} is not uploaded (GpuRenderer::upload_views_for)"),
            });
        }
        let rank_preferences = weights::rank_preferences(&blend_weights, params.view_rank_exponent);
        let sizes = level_sizes(camera.width_px as usize, camera.height_px as usize, params.levels);
        let previous_plane = previous.and_then(|p| p.plane);
        let plane = (params.lambda_plane > 0.0)
            .then(|| InverseDepthPlane::fit_points(camera, &inputs.positions_world, previous_plane.as_ref()))
            .flatten();
        // Where the novel view shows the static scene, views with a plate give its color.
        let static_mask = match inputs.static_points {
            Some(statics) => {
                ctx.set_stage(0, "splat");
                let geometry = plates::MaskGeometry::of(params, camera);
                self.static_mask.static_mask(ctx, &self.splat, params, &inputs.cloud, statics, &geometry)?
            }
            None => None,
        };
        let mut state: Option<(GpuImage, GpuImage)> = None;
        let mut solutions = Vec::with_capacity(params.levels);
        let mut view_weight = None;
        for level in (0..params.levels).rev() {
            let (w, h) = sizes[level];
            let cam = camera_at(camera, w, h);
            ctx.set_stage(level, "splat");
            let points = self.splat.project_cloud(ctx, &inputs.cloud, &cam)?;
            self.consistency.drop_inconsistent(ctx, &points, params.sparse_consistency, params.sparse_surround_px)?;
            // Each point attached over its footprint; the counters give the coverage after.
            let (sparse, counters) = self.splat.with_footprint(ctx, &points, params.sparse_footprint_px)?;
            ctx.set_stage(level, "temporal");
            let prev: Option<GpuSplat> = match previous
                .filter(|_| level < params.temporal_levels)
                .and_then(|p| p.levels.get(level).map(|l| (p.camera, l)))
            {
                Some((prev_camera, (d, c))) => Some(self.splat.warp_frame(ctx, &camera_at(&prev_camera, c.width, c.height), d, c, &cam)?),
                None => None,
            };
            let view_images: Vec<(Camera, &GpuImage, Option<&GpuImage>)> = chosen
                .iter()
                .map(|&s| {
                    let (view_camera, levels) = &inputs.views[s];
                    let levels = levels.as_deref().unwrap_or_default();
                    let image = &levels[level.min(levels.len() - 1)];
                    let plate = inputs.plates[s].as_ref().map(|p| &p[level.min(p.len() - 1)]);
                    (camera_at(view_camera, image.width, image.height), image, plate)
                })
                .collect();
            // Initial guess: push-pull filled sparse depth at the coarsest level, the upsampled
            // depth below; color by the rank-weighted blend of the visible warps.
            ctx.set_stage(level, "push-pull");
            let (depth, fallback_color) = match state.take() {
                None => {
                    let mut fallback = [0.0f32; 3];
                    fallback[0] = FALLBACK_DEPTH;
                    let depth = self.images.push_pull(ctx, &sparse.depth, &sparse.mask, fallback)?;
                    let color = self.images.push_pull(ctx, &sparse.color, &sparse.mask, FALLBACK_COLOR)?;
                    (depth, color)
                }
                Some((depth, color)) => (self.images.upsample(ctx, &depth, w, h)?, self.images.upsample(ctx, &color, w, h)?),
            };
            ctx.set_stage(level, "warp");
            let mut warps = self.warps.warp_views(ctx, &cam, &depth, &view_images, params.visibility_tolerance, static_mask.as_ref())?;
            ctx.set_stage(level, "weights");
            let color = self.blend.blend(ctx, &warps, &fallback_color, &blend_weights)?;
            ctx.set_stage(level, "temporal");
            // Temporal terms from the fresh estimate of this level.
            let (temporal_depth, temporal_color) = match &prev {
                Some(p) => {
                    let w_t = self.temporal.temporal_weights(ctx, p, &warps, params.sigma)?;
                    self.temporal.temporal_terms(ctx, &w_t, p, &counters, params.lambda_t, params.temporal_coverage_scaling)?
                }
                None => (GpuImage::zeroed(ctx, w, h, 2)?, GpuImage::zeroed(ctx, w, h, 4)?),
            };
            ctx.set_stage(level, "splat");
            let sparse_color_mask = self.splat.pack_color_mask(ctx, &sparse)?;
            // The points' support window, for the plane and the rank preference alike.
            let rows = match plane.is_some() || params.view_rank_exponent > 0.0 {
                true => Some(self.assemble.support_rows(ctx, &points.mask, level)?),
                false => None,
            };
            // The plane's pull joins the temporal terms of the depth system.
            let temporal_depth = match (plane, &rows) {
                (Some(p), Some(rows)) => self.assemble.plane_prior(ctx, params, rows, &temporal_depth, &p.in_pixels(&cam), level)?,
                _ => temporal_depth,
            };
            // Where points are scarce the color follows the best-ranked view.
            let unsupported = match &rows {
                Some(rows) if params.view_rank_exponent > 0.0 => Some(self.rank.unsupported(ctx, rows, level, params.view_rank_support)?),
                _ => None,
            };
            let mut last_w_p = None;
            for _ in 0..params.outer_iterations_at(level) {
                ctx.set_stage(level, "weights");
                let w_p = self.assemble.projection_weights(ctx, params, &color, &warps)?;
                ctx.set_stage(level, "depth system");
                let sys = self.assemble.depth_system(
                    ctx,
                    params,
                    &color,
                    &w_p,
                    &warps.visibility,
                    &sparse_color_mask,
                    &sparse.depth,
                    &temporal_depth,
                )?;
                ctx.set_stage(level, "depth solve");
                self.solver.solve_on_gpu(ctx, &sys, &depth, params.depth_sweeps, params.relaxation)?;
                ctx.set_stage(level, "warp");
                warps = self.warps.warp_views(ctx, &cam, &depth, &view_images, params.visibility_tolerance, static_mask.as_ref())?;
                ctx.set_stage(level, "weights");
                let w_p = self.assemble.projection_weights(ctx, params, &color, &warps)?;
                if let Some(unsupported) = &unsupported {
                    self.rank.apply(ctx, &w_p, unsupported, &rank_preferences)?;
                }
                ctx.set_stage(level, "color system");
                let sys = self.assemble.color_system(ctx, params, &warps.colors, &w_p, &temporal_color)?;
                ctx.set_stage(level, "color solve");
                self.solver.solve_on_gpu(ctx, &sys, &color, params.color_sweeps, params.relaxation)?;
                if level == 0 {
                    last_w_p = Some(w_p);
                }
            }
            if let Some(w_p) = last_w_p.take() {
                view_weight = Some(self.assemble.view_weight(ctx, params, &w_p)?);
            }
            solutions.push((self.copy(ctx, &depth)?, self.copy(ctx, &color)?));
            state = Some((depth, color));
        }
        solutions.reverse();
        Ok(GpuFrame { camera: *camera, levels: solutions, view_weight, views_used: chosen.len(), plane: plane.map(|p| p.to_world(camera)) })
    }

    /// A copy of `image` (the level's solution, kept while the next level overwrites its own).
    fn copy(&self, ctx: &GpuContext, image: &GpuImage) -> Result<GpuImage, GpuError> {
        let out = GpuImage::zeroed(ctx, image.width, image.height, image.channels)?;
        let bytes = (image.width * image.height * image.channels * 4) as u64;
        ctx.encode(|encoder| encoder.copy_buffer_to_buffer(&image.buffer, 0, &out.buffer, 0, bytes));
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use dynview_core::camera::{Camera, Intrinsics, Rigid3};
    use dynview_core::raster::Raster;
    use dynview_core::render::{InputView, RenderParams, TimeStepInputs};
    use glam::DVec3;

    use super::{GpuInputs, GpuRenderer};
    use crate::GpuContext;

    fn camera(x: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics::from_vertical_fov(0.9, 32, 24),
            camera_from_world: Rigid3::camera_from_world_looking_at(DVec3::new(x, 0.0, 4.0), DVec3::ZERO, DVec3::Y),
            width_px: 32,
            height_px: 24,
        }
    }

    /// Three views of one time step, each with the plate pyramid given.
    fn step(plates: &[Arc<Vec<dynview_core::RgbRaster>>], shade: f32) -> TimeStepInputs {
        let views = plates
            .iter()
            .enumerate()
            .map(|(i, plate)| {
                InputView::new(camera(i as f64 - 1.0), Raster::filled(32, 24, [shade; 3]), 2).with_plate_pyramid(plate.clone())
            })
            .collect();
        TimeStepInputs { cloud: Default::default(), views, static_points: 0 }
    }

    #[test]
    fn a_plate_shared_by_the_time_steps_is_uploaded_once() {
        let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
        let renderer = GpuRenderer::new(&ctx);
        let params = RenderParams { views: 2, ..RenderParams::default() };
        let plate = |v: f32| Arc::new(dynview_core::render::pyramid::build(Raster::filled(32, 24, [v; 3]), 2));
        let plates = [plate(0.1), plate(0.2), plate(0.3)];
        let (first, second) = (step(&plates, 0.5), step(&plates, 0.6));
        let novel = camera(-0.2);
        let upload = |inputs: &TimeStepInputs| {
            let mut gpu = GpuInputs::upload_cloud(&ctx, inputs).unwrap();
            renderer.upload_views_for(&ctx, &params, &novel, &mut gpu, inputs).unwrap();
            gpu
        };
        let (a, b) = (upload(&first), upload(&second));
        let used = a.uploaded_views();
        assert_eq!(used.len(), 2);
        for &v in &used {
            let (pa, pb) = (a.plates[v].as_ref().unwrap(), b.plates[v].as_ref().unwrap());
            assert!(std::rc::Rc::ptr_eq(pa, pb), "view {v}: the second step uploaded its plate again");
        }
        // A plate of its own (another pyramid, as after a change of depth) is uploaded anew.
        let mut other = plates.clone();
        other[used[0]] = plate(0.1);
        let c = upload(&step(&other, 0.7));
        assert!(!std::rc::Rc::ptr_eq(a.plates[used[0]].as_ref().unwrap(), c.plates[used[0]].as_ref().unwrap()));
        assert!(std::rc::Rc::ptr_eq(a.plates[used[1]].as_ref().unwrap(), c.plates[used[1]].as_ref().unwrap()));
    }
}
