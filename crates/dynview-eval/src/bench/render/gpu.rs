//! The GPU's side of the renderer benchmark: a streaming frame timed and counted, a profiled
//! frame per level and stage, and a playback frame (upload, frame, read-back).

use std::fmt::Write as _;
use std::time::Instant;

use dynview_core::Camera;
use dynview_core::render::{RenderParams, TimeStepInputs};

/// Streaming GPU frames in a row before any is timed: the buffer pool and the bind-group cache
/// settle (the frames take the same buffers in the same roles) within a few frames.
pub(super) const GPU_SETTLING_FRAMES: usize = 6;

/// A streaming GPU frame: wall milliseconds (median; the clock stops when the GPU has
/// finished) and the work recorded for the last one.
pub(super) struct GpuFrameFigures {
    pub(super) wall_ms: f64,
    /// The render call alone (median): recording and submitting the frame on the host, with
    /// the plane fit, before waiting for the GPU.
    pub(super) host_ms: f64,
    pub(super) counters: dynview_gpu::GpuCounters,
    /// Buffers each of the views' per-pixel images takes at the finest level.
    pub(super) view_buffers: usize,
}

/// A playback frame's parts (medians, milliseconds): the time step's upload, the frame
/// (recorded, submitted and finished), the read-back of its color and depth, and the whole.
pub(super) struct PlaybackFigures {
    /// Megabytes uploaded a frame.
    pub(super) up_mb: f64,
    pub(super) upload_ms: f64,
    pub(super) frame_ms: f64,
    pub(super) download_ms: f64,
    pub(super) total_ms: f64,
}

/// One size's GPU measurement: the device, its renderer, and the frame rendered.
#[derive(Clone, Copy)]
pub(super) struct GpuCase<'a> {
    pub(super) ctx: &'a dynview_gpu::GpuContext,
    pub(super) renderer: &'a dynview_gpu::GpuRenderer,
    pub(super) params: &'a RenderParams,
    pub(super) camera: &'a Camera,
    pub(super) inputs: &'a TimeStepInputs,
}

impl GpuCase<'_> {
    /// Streaming GPU frames (each with the previous one's temporal terms; inputs already uploaded).
    pub(super) fn frame_figures(&self, runs: usize) -> anyhow::Result<GpuFrameFigures> {
        let Self { ctx, renderer, params, camera, inputs } = *self;
        let uploaded = dynview_gpu::GpuInputs::upload(ctx, inputs)?;
        ctx.wait()?;
        let mut previous = None;
        let mut times = Vec::new();
        let mut host_times = Vec::new();
        let mut counters = dynview_gpu::GpuCounters::default();
        for run in 0..GPU_SETTLING_FRAMES + runs {
            let before = ctx.counters();
            let start = Instant::now();
            let frame = renderer.render(ctx, params, camera, &uploaded, previous.as_ref())?;
            let host_ms = start.elapsed().as_secs_f64() * 1000.0;
            ctx.wait()?;
            if run >= GPU_SETTLING_FRAMES {
                times.push(start.elapsed().as_secs_f64() * 1000.0);
                host_times.push(host_ms);
                counters = ctx.counters() - before;
            }
            previous = Some(frame);
        }
        times.sort_by(f64::total_cmp);
        host_times.sort_by(f64::total_cmp);
        let views = params.views.min(inputs.views.len());
        let view_buffers = dynview_gpu::ViewChunks::for_device(ctx, camera.width_px as usize, camera.height_px as usize, views)?.len();
        Ok(GpuFrameFigures { wall_ms: times[times.len() / 2], host_ms: host_times[host_times.len() / 2], counters, view_buffers })
    }

    /// Frames as playback renders them (`dynview_gpu::GpuStreamingRenderer`): every frame uploads
    /// its time step's cloud and the finest level of the views it renders from (here the same
    /// inputs, uploaded afresh each time), renders with the previous frame's temporal terms, and
    /// reads its color and depth back.
    pub(super) fn playback_figures(&self, runs: usize) -> anyhow::Result<PlaybackFigures> {
        let Self { ctx, renderer, params, camera, inputs } = *self;
        let mut parts: [Vec<f64>; 4] = Default::default();
        let mut previous = None;
        let mut up_mb = 0.0;
        for run in 0..GPU_SETTLING_FRAMES + runs {
            let start = Instant::now();
            let mut uploaded = dynview_gpu::GpuInputs::upload_cloud(ctx, inputs)?;
            renderer.upload_views_for(ctx, params, camera, &mut uploaded, inputs)?;
            ctx.wait()?;
            let uploaded_at = start.elapsed();
            up_mb = uploaded_bytes(inputs, &uploaded) as f64 / 1e6;
            let frame = renderer.render(ctx, params, camera, &uploaded, previous.as_ref())?;
            ctx.wait()?;
            let rendered_at = start.elapsed();
            let color = frame.color().download_rgb(ctx)?;
            let depth = frame.depth().download(ctx)?;
            let done_at = start.elapsed();
            anyhow::ensure!(color.data.len() == depth.len(), "read-back sizes disagree");
            if run >= GPU_SETTLING_FRAMES {
                let ms = |d: std::time::Duration| d.as_secs_f64() * 1000.0;
                parts[0].push(ms(uploaded_at));
                parts[1].push(ms(rendered_at - uploaded_at));
                parts[2].push(ms(done_at - rendered_at));
                parts[3].push(ms(done_at));
            }
            previous = Some(frame);
        }
        let [upload_ms, frame_ms, download_ms, total_ms] = parts.map(|mut v| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        });
        Ok(PlaybackFigures { up_mb, upload_ms, frame_ms, download_ms, total_ms })
    }

    /// GPU time of one profiled streaming frame (milliseconds, summed) and per level and stage as
    /// a markdown table, or `None` when the adapter has no timestamp queries.
    pub(super) fn stage_table(&self) -> anyhow::Result<Option<(f64, String)>> {
        let Self { ctx, renderer, params, camera, inputs } = *self;
        let uploaded = dynview_gpu::GpuInputs::upload(ctx, inputs)?;
        // A streaming frame: the previous one feeds the temporal terms.
        let previous = renderer.render(ctx, params, camera, &uploaded, None)?;
        ctx.wait()?;
        if !ctx.start_profile() {
            return Ok(None);
        }
        drop(renderer.render(ctx, params, camera, &uploaded, Some(&previous))?);
        let stages = ctx.finish_profile()?;
        let total_ms: f64 = stages.iter().map(|s| s.ms).sum();
        let mut table = format!(
            "| level | {} | sum | passes |\n| ---: |{} ---: | ---: |\n",
            GPU_STAGES.join(" | "),
            " ---: |".repeat(GPU_STAGES.len())
        );
        for level in (0..params.levels).rev() {
            // (`0.0 +`: an empty f64 sum is -0.0.)
            let at = |stage: &str| 0.0 + stages.iter().filter(|s| s.level == level && s.stage == stage).map(|s| s.ms).sum::<f64>();
            let cells: Vec<String> = GPU_STAGES.iter().map(|s| format!("{:.2}", at(s))).collect();
            let sum: f64 = stages.iter().filter(|s| s.level == level).map(|s| s.ms).sum();
            let passes: usize = stages.iter().filter(|s| s.level == level).map(|s| s.passes).sum();
            let _ = writeln!(table, "| {level} | {} | {sum:.2} | {passes} |", cells.join(" | "));
        }
        // Per stage over all levels: the bytes its dispatches bound against its time.
        let _ = writeln!(table, "\n| stage | GPU ms | MB bound | GB/s (bound / time) |\n| --- | ---: | ---: | ---: |");
        for stage in GPU_STAGES {
            let ms: f64 = stages.iter().filter(|s| s.stage == stage).map(|s| s.ms).sum();
            let bytes: u64 = stages.iter().filter(|s| s.stage == stage).map(|s| s.bytes_bound).sum();
            let rate = if ms > 0.0 { bytes as f64 / (ms * 1e6) } else { 0.0 };
            let _ = writeln!(table, "| {stage} | {ms:.2} | {:.1} | {rate:.1} |", bytes as f64 / 1e6);
        }
        Ok(Some((total_ms, table)))
    }
}

/// Bytes a playback frame uploads: the cloud (a f32 position and an 8-bit color a point) and
/// the finest level of each view uploaded, its plate too (f32 RGB).
fn uploaded_bytes(inputs: &TimeStepInputs, uploaded: &dynview_gpu::GpuInputs) -> usize {
    let finest = |v: &dynview_core::render::InputView| {
        v.levels.first().map_or(0, |l| l.data.len()) + v.plate.as_ref().and_then(|p| p.first()).map_or(0, |l| l.data.len())
    };
    let pixels: usize = uploaded.uploaded_views().into_iter().map(|i| finest(&inputs.views[i])).sum();
    pixels * std::mem::size_of::<[f32; 3]>() + inputs.cloud.len() * 15
}

/// Stages of the GPU renderer, in the order of the table.
const GPU_STAGES: [&str; 9] =
    ["splat", "temporal", "push-pull", "warp", "weights", "depth system", "depth solve", "color system", "color solve"];
