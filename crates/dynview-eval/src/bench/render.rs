//! `cargo xtask bench` (`dynview-eval bench`): milliseconds per frame of the full method at several resolutions, per
//! pyramid level and per stage, on this machine with all cores (release build), and on the GPU
//! that wgpu finds (lavapipe without one: correctness, not speed).

use std::borrow::Cow;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use dynview_core::Camera;
use dynview_core::render::{LevelTimings, RenderHooks, RenderParams, TimeStepInputs, render_frame};
use dynview_core::scene::ScenePackage;
use dynview_interchange::camera_path::parse_path;
use dynview_synth::SynthConfig;

use crate::paths::workspace_root;

mod gpu;
use gpu::{GPU_SETTLING_FRAMES, GpuCase};

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
    /// Time a prepared scene package instead of the synthetic event: the time step and camera
    /// of `--camera-path`'s first frame, the camera resized to each of `--sizes` (the inputs
    /// keep the package's size).
    #[arg(long, requires = "camera_path")]
    pub scene: Option<PathBuf>,
    /// Camera path (nerfstudio or dynview JSON, as `dynview render --path` reads) whose first
    /// frame `--scene` is seen from.
    #[arg(long, requires = "scene")]
    pub camera_path: Option<PathBuf>,
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

/// The time step of `path`'s first frame in the package at `scene`, and its camera.
pub fn package_frame(scene: &Path, path: &Path) -> anyhow::Result<(TimeStepInputs, Camera)> {
    let package = ScenePackage::open(scene).with_context(|| format!("opening the scene package {}", scene.display()))?;
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let frame = *parse_path(&bytes, &path.display().to_string(), None)?
        .first()
        .with_context(|| format!("{}: the camera path has no frame", path.display()))?;
    let t = frame.time.time_step(package.manifest().time_step_count);
    let inputs = package.time_step_inputs(t, RenderParams::default().levels).with_context(|| format!("loading time step {t}"))?;
    println!("{}: time step {t}, {} views, {} points", scene.display(), inputs.views.len(), inputs.cloud.len());
    Ok((inputs, frame.camera))
}

/// The benchmark: prints the tables and writes them to `target/bench/report.md`.
pub fn run(options: Options) -> anyhow::Result<()> {
    let Options { sizes, gpu_only, webgpu_limits, sweeps, runs, scene, camera_path } = options;
    let package = match (&scene, &camera_path) {
        (Some(scene), Some(path)) => Some(package_frame(scene, path)?),
        _ => None,
    };
    let runs = usize::from(runs);
    let params = RenderParams::default();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut report = String::new();
    let subject = scene.as_ref().map_or("the synthetic event".to_string(), |s| format!("the package {}", s.display()));
    let _ = writeln!(
        report,
        "Full method on {subject}, {} views, {} levels, {threads} threads, median of {runs} runs:\n",
        params.views, params.levels
    );
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
        // The package's inputs are shared by every size; the synthetic event is made per size.
        let (inputs, camera) = match &package {
            Some((inputs, camera)) => (Cow::Borrowed(inputs), camera.resized(w, h)),
            None => bench_event(w, h).map(|(inputs, camera)| (Cow::Owned(inputs), camera))?,
        };
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
        let case = gpu.as_ref().map(|(ctx, renderer)| GpuCase { ctx, renderer, params: &params, camera: &camera, inputs: &inputs });
        let gpu_figures = case.map(|c| c.frame_figures(runs)).transpose()?;
        let gpu_ms = gpu_figures.as_ref().map(|f| f.wall_ms);
        let gpu_stages = case.map(|c| c.stage_table()).transpose()?.flatten();
        if let Some(case) = case {
            let p = case.playback_figures(runs)?;
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

#[cfg(test)]
mod tests {
    use dynview_synth::SynthConfig;

    use super::*;

    #[test]
    fn a_package_is_timed_at_its_paths_first_step_and_camera() {
        let dir = tempfile::tempdir().unwrap();
        let config = SynthConfig { frames: 3, width: 64, height: 36, videos: false, ..SynthConfig::default() };
        dynview_synth::generate(&config, dir.path(), &|_, _, _| {}).unwrap();
        let path_file = dir.path().join("camera_path.json");
        let path = parse_path(&std::fs::read(&path_file).unwrap(), "camera_path.json", None).unwrap();
        let package = ScenePackage::open(dir.path().join("scene")).unwrap();
        let step = path[0].time.time_step(package.manifest().time_step_count);
        let (inputs, camera) = package_frame(&dir.path().join("scene"), &path_file).unwrap();
        assert_eq!(camera, path[0].camera);
        let expected = package.time_step_inputs(step, RenderParams::default().levels).unwrap();
        assert_eq!(inputs.cloud.positions_world, expected.cloud.positions_world);
        assert_eq!(inputs.views.len(), package.manifest().cameras.len());

        let missing = dir.path().join("no_path.json");
        let error = format!("{:#}", package_frame(&dir.path().join("scene"), &missing).unwrap_err());
        assert!(error.contains("no_path.json"), "{error}");
        let error = format!("{:#}", package_frame(&dir.path().join("no_scene"), &path_file).unwrap_err());
        assert!(error.contains("no_scene"), "{error}");
    }
}
