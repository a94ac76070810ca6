//! `cargo xtask bench` (`dynview-eval bench`): milliseconds per frame of the full method at several resolutions, per
//! pyramid level and per stage, on this machine with all cores (release build), and on the GPU
//! that wgpu finds (lavapipe without one: correctness, not speed).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use dynview_core::Camera;
use dynview_core::render::{LevelTimings, RenderHooks, RenderParams, TimeStepInputs, render_frame};
use dynview_core::scene::ScenePackage;
use dynview_interchange::camera_path::parse_path;
use dynview_synth::SynthConfig;

use crate::paths::workspace_root;

/// Options of `dynview-eval bench` (`cargo xtask bench`).
#[derive(Debug, clap::Args)]
pub struct Options {
    /// Output sizes, `WxH` comma-separated (the synthetic event is made at each size: its
    /// input views have the output's size).
    #[arg(long, value_delimiter = ',', value_parser = parse_size, default_values = ["480x270", "960x540", "1920x1080"])]
    pub sizes: Vec<(u32, u32)>,
    /// Time the GPU only (for sizes where the CPU takes minutes a frame).
    #[arg(long)]
    pub gpu_only: bool,
    /// Ask the GPU for WebGPU's default limits (128 MiB a storage binding, 256 MiB a buffer), as
    /// a browser on a modest device gives, instead of the adapter's own: large outputs split
    /// their views into several buffers.
    #[arg(long)]
    pub webgpu_limits: bool,
    /// The GPU's red-black sweep kernel: `auto` (per colour on a CPU adapter, tiled on a GPU),
    /// `per-colour` or `tiled`.
    #[arg(long, value_enum, default_value_t = Sweeps::Auto)]
    pub sweeps: Sweeps,
    /// Timed frames per size and path (after the warm-up); the median is reported.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u16).range(1..))]
    pub runs: u16,
}

/// The `--sweeps` choice.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Sweeps {
    /// The adapter's default (`dynview_gpu::SweepKernel::for_adapter`).
    Auto,
    /// One colour per dispatch.
    PerColour,
    /// Up to four colours per dispatch on workgroup-local tiles.
    Tiled,
}

/// `WxH` (both 16 to 8192).
fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let parsed = text.split_once('x').and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if (16..=8192).contains(&w) && (16..=8192).contains(&h) => Ok((w, h)),
        _ => Err(format!("`{text}` is not WIDTHxHEIGHT with each side 16 to 8192")),
    }
}

/// A one-frame synthetic event at `width x height` (made once, cached under target/bench/).
pub fn bench_event(width: u32, height: u32) -> anyhow::Result<(TimeStepInputs, Camera)> {
    let dir = workspace_root().join(format!("target/bench/event_{width}x{height}"));
    if !dir.join(dynview_synth::SYNTH_MARKER).is_file() {
        println!("making a {width}x{height} synthetic frame in {} ...", dir.display());
        let config = SynthConfig { frames: 1, width, height, videos: false, ..SynthConfig::default() };
        dynview_synth::generate(&config, &dir, &|_, _, _| {})?;
    }
    let package = ScenePackage::open(dir.join("scene"))?;
    let inputs = package.time_step_inputs(0, RenderParams::default().levels)?;
    let path = parse_path(&std::fs::read(dir.join("camera_path.json"))?, "camera_path.json", None)?;
    let camera = path.first().context("empty camera path")?.camera;
    Ok((inputs, camera))
}

/// The benchmark: prints the tables and writes them to `target/bench/report.md`.
pub fn run(options: Options) -> anyhow::Result<()> {
    let Options { sizes, gpu_only, webgpu_limits, sweeps, runs } = options;
    let runs = usize::from(runs);
    let params = RenderParams::default();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut report = String::new();
    let _ = writeln!(report, "Full method, {} views, {} levels, {threads} threads, median of {runs} runs:\n", params.views, params.levels);
    let context = match webgpu_limits {
        true => dynview_gpu::GpuContext::with_limits_blocking(dynview_gpu::wgpu::Limits::default()),
        false => dynview_gpu::GpuContext::new_blocking(),
    };
    let gpu = match context {
        Ok(ctx) => {
            let kernel = match sweeps {
                Sweeps::Auto => dynview_gpu::SweepKernel::for_adapter(&ctx.adapter_info),
                Sweeps::PerColour => dynview_gpu::SweepKernel::PerColour,
                Sweeps::Tiled => dynview_gpu::SweepKernel::Tiled,
            };
            let renderer = dynview_gpu::GpuRenderer::with_sweep_kernel(&ctx, kernel);
            let limits = if webgpu_limits { "WebGPU's default limits" } else { "the adapter's limits" };
            let _ = writeln!(
                report,
                "GPU: {} ({:?}, {}), {limits}: {} MiB a storage binding; sweep kernel {kernel:?}.\n",
                ctx.adapter_info.name,
                ctx.adapter_info.backend,
                ctx.adapter_info.driver,
                ctx.storage_limit_bytes() >> 20
            );
            Some((ctx, renderer))
        }
        Err(e) => {
            let _ = writeln!(report, "GPU: none ({e}).\n");
            None
        }
    };
    let _ = writeln!(report, "| output | CPU ms/frame | frames/s | paper (6.8 s) / ours | GPU ms/frame (streaming) | CPU / GPU |");
    let _ = writeln!(report, "| --- | ---: | ---: | ---: | ---: | ---: |");
    let mut details = String::new();
    let mut gpu_rows = String::new();
    let mut playback_rows = String::new();
    for (w, h) in sizes {
        let (inputs, camera) = bench_event(w, h)?;
        let origin = Instant::now();
        let clock = move || origin.elapsed().as_secs_f64() * 1000.0;
        let mut cpu_runs = Vec::new();
        for run in 0..=runs {
            if gpu_only {
                break;
            }
            let mut hooks = RenderHooks { clock: Some(&clock), ..RenderHooks::default() };
            let start = Instant::now();
            let out = render_frame(&params, &camera, &inputs, None, &mut hooks)?;
            let ms = start.elapsed().as_secs_f64() * 1000.0;
            if run > 0 {
                cpu_runs.push((ms, out.timings));
            }
        }
        cpu_runs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let cpu = cpu_runs.get(cpu_runs.len() / 2);
        let gpu_figures = match &gpu {
            Some((ctx, renderer)) => Some(gpu_frame_figures(ctx, renderer, &params, &camera, &inputs, runs)?),
            None => None,
        };
        let gpu_ms = gpu_figures.as_ref().map(|f| f.wall_ms);
        let gpu_stages = match &gpu {
            Some((ctx, renderer)) => gpu_stage_table(ctx, renderer, &params, &camera, &inputs)?,
            None => None,
        };
        if let Some((ctx, renderer)) = &gpu {
            let p = gpu_playback_figures(ctx, renderer, &params, &camera, &inputs, runs)?;
            let _ = writeln!(
                playback_rows,
                "| {w}x{h} | {:.1} | {:.0} | {:.1} | {:.1} | {:.1} | {:.1} |",
                p.total_ms,
                p.up_mb,
                p.upload_ms,
                p.frame_ms,
                p.download_ms,
                1000.0 / p.total_ms
            );
        }
        if let Some(f) = &gpu_figures {
            let c = &f.counters;
            let gpu_ms_sum = gpu_stages.as_ref().map_or("-".to_string(), |(sum, _)| format!("{sum:.2}"));
            let _ = writeln!(
                gpu_rows,
                "| {w}x{h} | {:.1} | {:.1} | {gpu_ms_sum} | {} | {} | {} | {} | {} | {:.0} | {} |",
                f.wall_ms,
                f.host_ms,
                c.dispatches,
                c.passes,
                c.bind_groups_created,
                c.submits,
                c.uniform_bytes,
                c.bytes_bound as f64 / 1e6,
                f.view_buffers
            );
        }
        let (gpu_cell, ratio_cell) = match (gpu_ms, cpu) {
            (Some(g), Some((ms, _))) => (format!("{g:.1}"), format!("{:.2}", ms / g)),
            (Some(g), None) => (format!("{g:.1}"), "-".into()),
            (None, _) => ("-".into(), "-".into()),
        };
        let cpu_cells = cpu.map_or("- | - | -".to_string(), |(ms, _)| format!("{ms:.0} | {:.2} | {:.1}x", 1000.0 / ms, 6800.0 / ms));
        let _ = writeln!(report, "| {w}x{h} | {cpu_cells} | {gpu_cell} | {ratio_cell} |");
        if let Some((_, timings)) = cpu {
            let _ = writeln!(details, "\n{w}x{h}: per level and stage (ms)\n");
            let _ = writeln!(
                details,
                "| level | size | sparse | push-pull | warp | visibility | weights | depth solve | color solve | total |"
            );
            let _ = writeln!(details, "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
            for l in &timings.levels {
                let _ = writeln!(details, "{}", level_row(l));
            }
        }
        if let Some((_, table)) = gpu_stages {
            let _ = writeln!(
                details,
                "\n{w}x{h} on the GPU, a streaming frame: per level and stage (ms of GPU time from timestamp queries; \
                 the rest of the wall time is the host encoding dispatches)\n\n{table}"
            );
        }
        let cpu_ms = cpu.map_or("-".to_string(), |(ms, _)| format!("{ms:.0} ms"));
        println!("{w}x{h}: CPU {cpu_ms}, GPU {}", gpu_ms.map_or("-".to_string(), |g| format!("{g:.1} ms")));
    }
    if !gpu_rows.is_empty() {
        let _ = writeln!(
            report,
            "\nGPU, a streaming frame (after {GPU_SETTLING_FRAMES} frames in a row): wall ms (median of {runs}), host ms (the \
             render call alone: recording and submitting on the host, median), GPU ms (sum of the timestamp queries of one \
             profiled frame), the work recorded per frame, and the buffers the views' images take (more than 1 where one \
             binding cannot hold them all)\n\n\
             | output | wall ms | host ms | GPU ms | dispatches | passes | bind groups created | submits | uniform bytes | MB bound | view buffers |\n\
             | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n{gpu_rows}"
        );
    }
    if !playback_rows.is_empty() {
        let _ = writeln!(
            report,
            "\nGPU, a playback frame (every frame a new time step, as `dynview render --gpu` plays: the time step's \
             cloud and the views the frame renders from uploaded, the frame rendered, its color and depth read back; \
             the viewer does the same but draws the color instead of reading it back; medians of {runs}): MB up (the \
             cloud and the finest level of each view used, with its plate), then the milliseconds of each part\n\n\
             | output | wall ms | MB up | upload ms | frame ms | read-back ms | frames/s |\n\
             | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n{playback_rows}"
        );
    }
    println!("\n{report}{details}");
    let out = workspace_root().join("target/bench/report.md");
    write_report(&out, &format!("{report}{details}"))?;
    println!("(also written to {})", out.display());
    Ok(())
}

/// Streaming GPU frames in a row before any is timed: the buffer pool and the bind-group cache
/// settle (the frames take the same buffers in the same roles) within a few frames.
const GPU_SETTLING_FRAMES: usize = 6;

/// A streaming GPU frame: wall milliseconds (median; the clock stops when the GPU has
/// finished) and the work recorded for the last one.
struct GpuFrameFigures {
    wall_ms: f64,
    /// The render call alone (median): recording and submitting the frame on the host, with
    /// the plane fit, before waiting for the GPU.
    host_ms: f64,
    counters: dynview_gpu::GpuCounters,
    /// Buffers each of the views' per-pixel images takes at the finest level.
    view_buffers: usize,
}

/// Streaming GPU frames (each with the previous one's temporal terms; inputs already uploaded).
fn gpu_frame_figures(
    ctx: &dynview_gpu::GpuContext,
    renderer: &dynview_gpu::GpuRenderer,
    params: &RenderParams,
    camera: &Camera,
    inputs: &TimeStepInputs,
    runs: usize,
) -> anyhow::Result<GpuFrameFigures> {
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

/// A playback frame's parts (medians, milliseconds): the time step's upload, the frame
/// (recorded, submitted and finished), the read-back of its color and depth, and the whole.
struct PlaybackFigures {
    /// Megabytes uploaded a frame.
    up_mb: f64,
    upload_ms: f64,
    frame_ms: f64,
    download_ms: f64,
    total_ms: f64,
}

/// Frames as playback renders them (`dynview_gpu::GpuStreamingRenderer`): every frame uploads
/// its time step's cloud and the finest level of the views it renders from (here the same
/// inputs, uploaded afresh each time), renders with the previous frame's temporal terms, and
/// reads its color and depth back.
fn gpu_playback_figures(
    ctx: &dynview_gpu::GpuContext,
    renderer: &dynview_gpu::GpuRenderer,
    params: &RenderParams,
    camera: &Camera,
    inputs: &TimeStepInputs,
    runs: usize,
) -> anyhow::Result<PlaybackFigures> {
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

/// GPU time of one profiled streaming frame (milliseconds, summed) and per level and stage as
/// a markdown table, or `None` when the adapter has no timestamp queries.
fn gpu_stage_table(
    ctx: &dynview_gpu::GpuContext,
    renderer: &dynview_gpu::GpuRenderer,
    params: &RenderParams,
    camera: &Camera,
    inputs: &TimeStepInputs,
) -> anyhow::Result<Option<(f64, String)>> {
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
    let mut table =
        format!("| level | {} | sum | passes |\n| ---: |{} ---: | ---: |\n", GPU_STAGES.join(" | "), " ---: |".repeat(GPU_STAGES.len()));
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

fn level_row(l: &LevelTimings) -> String {
    format!(
        "| {} | {}x{} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
        l.level,
        l.width,
        l.height,
        l.sparse_ms,
        l.pushpull_ms,
        l.warp_ms,
        l.visibility_ms,
        l.weights_ms,
        l.depth_solve_ms,
        l.color_solve_ms,
        l.total_ms()
    )
}

fn write_report(path: &Path, text: &str) -> anyhow::Result<()> {
    dynview_core::fsutil::write_atomic(path, text.as_bytes())?;
    Ok(())
}
