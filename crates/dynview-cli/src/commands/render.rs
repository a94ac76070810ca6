//! `dynview render`: render a camera path through a scene package.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use dynview_core::camera::Camera;
use dynview_core::depth_io::{DepthScale, SCALE_FILE, depth_png_bytes};
use dynview_core::fsutil::write_atomic;
use dynview_core::raster::{RgbRaster, ScalarRaster};
use dynview_core::render::{Method, RenderHooks, RenderParams, StreamingRenderer, TimeStepInputs};
use dynview_core::scene::ScenePackage;
use dynview_gpu::{GpuContext, GpuStreamingRenderer, StreamRequest};
use dynview_interchange::camera_path::parse_path;

use crate::progress::StageBars;

/// Arguments of `dynview render`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The scene package folder.
    #[arg(long)]
    scene: PathBuf,
    /// Camera path: nerfstudio camera_path.json or dynview's own path format.
    #[arg(long)]
    path: PathBuf,
    /// Output folder: <i:05>.png, depth/<i:05>.png and depth/scale.json.
    #[arg(long)]
    out: PathBuf,
    /// Render every frame without the temporal terms.
    #[arg(long)]
    no_temporal: bool,
    /// JSON file of render parameters (any subset of RenderParams; the rest keep defaults).
    #[arg(long)]
    params: Option<PathBuf>,
    /// Method: full, no-temporal, blend, best-view or splat (overrides the params file).
    #[arg(long)]
    method: Option<String>,
    /// Output width (overrides the path's; needs --height too).
    #[arg(long, requires = "height")]
    width: Option<u32>,
    /// Output height (overrides the path's; needs --width too).
    #[arg(long, requires = "width")]
    height: Option<u32>,
    /// Render on the GPU (wgpu: Vulkan, Metal or DX12; lavapipe when no GPU). Full method and
    /// no-temporal only.
    #[arg(long)]
    gpu: bool,
}

/// The renderer a run uses: the CPU's streaming renderer, or the GPU's.
enum Backend {
    Cpu(StreamingRenderer),
    Gpu { ctx: Box<GpuContext>, renderer: Box<GpuStreamingRenderer> },
}

impl Backend {
    fn jump(&mut self) {
        match self {
            Self::Cpu(r) => r.jump(),
            Self::Gpu { renderer, .. } => renderer.jump(),
        }
    }

    /// Renders one frame; returns color, depth and the renderer's milliseconds.
    fn render(
        &mut self,
        params: &RenderParams,
        camera: &Camera,
        t: u32,
        inputs: &TimeStepInputs,
        clock: &dyn Fn() -> f64,
    ) -> anyhow::Result<(RgbRaster, ScalarRaster, f64)> {
        match self {
            Self::Cpu(renderer) => {
                let mut hooks = RenderHooks { clock: Some(clock), ..RenderHooks::default() };
                let output = renderer.render(params, camera, inputs, &mut hooks)?;
                let ms = output.timings.total_ms;
                Ok((output.color, output.depth, ms))
            }
            Self::Gpu { ctx, renderer } => {
                let start = clock();
                let request = StreamRequest { camera: *camera, time_step: t, inputs, streaming: true, keep: true };
                let (frame, _) = renderer.render(ctx, params, &request)?;
                let color = frame.color().download_rgb(ctx)?;
                let depth = frame.depth().download(ctx)?;
                let ms = clock() - start;
                let depth = ScalarRaster { width: color.width, height: color.height, data: depth };
                Ok((color, depth, ms))
            }
        }
    }
}

/// Writes each `(index, color, depth)` received as `out/<index>.png` and
/// `depth_dir/<index>.png` (each file replaced only once complete), until the sender is gone.
fn write_frames(
    inbox: &std::sync::mpsc::Receiver<(usize, RgbRaster, ScalarRaster)>,
    out: &Path,
    depth_dir: &Path,
    scale: DepthScale,
) -> anyhow::Result<()> {
    for (i, color, depth) in inbox {
        let color_path = out.join(format!("{i:05}.png"));
        let mut png = Vec::new();
        color.to_rgb8().write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
        write_atomic(&color_path, &png).with_context(|| format!("writing {}", color_path.display()))?;
        let depth_path = depth_dir.join(format!("{i:05}.png"));
        write_atomic(&depth_path, &depth_png_bytes(&depth, scale)?).with_context(|| format!("writing {}", depth_path.display()))?;
    }
    Ok(())
}

/// Reads the parameters file and applies the command-line overrides.
pub fn load_params(file: Option<&Path>, method: Option<&str>, no_temporal: bool) -> anyhow::Result<RenderParams> {
    let mut params = match file {
        Some(f) => {
            let text = fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
            serde_json::from_str(&text).with_context(|| format!("{}: not valid render parameters", f.display()))?
        }
        None => RenderParams::default(),
    };
    if let Some(m) = method {
        params.method = serde_json::from_value(serde_json::Value::String(m.to_owned()))
            .with_context(|| format!("unknown method {m:?}; known: full, no-temporal, blend, best-view, splat"))?;
    }
    if no_temporal && params.method == Method::Full {
        params.method = Method::NoTemporal;
    }
    params.validate()?;
    Ok(params)
}

/// Runs `dynview render`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let params = load_params(args.params.as_deref(), args.method.as_deref(), args.no_temporal)?;
    let package = ScenePackage::open(&args.scene).with_context(|| format!("opening scene package {}", args.scene.display()))?;
    let path_bytes = fs::read(&args.path).with_context(|| format!("reading {}", args.path.display()))?;
    let size = args.width.zip(args.height);
    let frames = parse_path(&path_bytes, &args.path.display().to_string(), size)?;
    let depth_dir = args.out.join("depth");
    fs::create_dir_all(&depth_dir).with_context(|| format!("creating {}", depth_dir.display()))?;
    if args.out.join(SCALE_FILE).exists() {
        bail!("{} looks like a depth folder; choose another --out", args.out.display());
    }

    // One depth scale for the whole sequence: deep enough for the farthest corner of the scene.
    let bounds = package.manifest().bounds;
    let max_depth = frames
        .iter()
        .map(|f| {
            let c = f.camera.center_world();
            let corner = |i: usize, v: [f64; 3]| (v[i] - c[i]).abs();
            (0..3).map(|i| corner(i, bounds.min).max(corner(i, bounds.max)).powi(2)).sum::<f64>().sqrt()
        })
        .fold(0.0, f64::max);
    let scale = DepthScale::for_max_depth(max_depth);
    write_atomic(&depth_dir.join(SCALE_FILE), serde_json::to_string_pretty(&scale)?.as_bytes())?;

    let clock_origin = Instant::now();
    let clock = move || clock_origin.elapsed().as_secs_f64() * 1000.0;
    let bars = StageBars::new();
    let mut renderer = if args.gpu {
        if !params.method.is_variational() {
            bail!("--gpu renders the full method and no-temporal; the {} baseline runs on the CPU", params.method.label());
        }
        let ctx = GpuContext::new_blocking()?;
        println!("GPU: {} ({:?})", ctx.adapter_info.name, ctx.adapter_info.backend);
        let renderer = GpuStreamingRenderer::new(&ctx, 1);
        Backend::Gpu { ctx: Box::new(ctx), renderer: Box::new(renderer) }
    } else {
        Backend::Cpu(StreamingRenderer::new())
    };
    let mut cached: Option<(u32, TimeStepInputs)> = None;
    let mut last_step: Option<u32> = None;
    let mut frame_ms = Vec::with_capacity(frames.len());
    let steps = package.time_step_count();
    // The PNGs are encoded and written on a thread of their own while the next frame renders
    // (at most two frames wait for it).
    let (to_writer, writer_inbox) = std::sync::mpsc::sync_channel::<(usize, RgbRaster, ScalarRaster)>(2);
    let writer = {
        let (out, depth_dir) = (args.out.clone(), depth_dir.clone());
        std::thread::spawn(move || write_frames(&writer_inbox, &out, &depth_dir, scale))
    };
    let mut render_all = || -> anyhow::Result<()> {
        for (i, frame) in frames.iter().enumerate() {
            let t = frame.time.time_step(steps);
            if cached.as_ref().is_none_or(|(ct, _)| *ct != t) {
                cached = Some((t, package.time_step_inputs(t, params.levels).with_context(|| format!("loading time step {t}"))?));
            }
            // Streaming only across consecutive (or equal) time steps; a jump drops the previous frame.
            if last_step.is_some_and(|lt| lt.abs_diff(t) > 1) {
                renderer.jump();
            }
            last_step = Some(t);
            let inputs = &cached.as_ref().map(|(_, inputs)| inputs).context("time step not loaded")?;
            let (color, depth, ms) =
                renderer.render(&params, &frame.camera, t, inputs, &clock).with_context(|| format!("rendering frame {i}"))?;
            frame_ms.push(ms);
            if to_writer.send((i, color, depth)).is_err() {
                // The writer stopped on an error, which joining it gives.
                break;
            }
            bars.update("render", i as u64 + 1, frames.len() as u64);
        }
        Ok(())
    };
    let rendered = render_all();
    // The frames sent so far are written (or the writer's error kept) before anything returns.
    drop(to_writer);
    let written = writer.join().map_err(|_| anyhow::anyhow!("the thread writing the frames panicked"))?;
    rendered?;
    written?;
    bars.finish();
    println!(
        "rendered {} frames with {} on the {} into {} ({})",
        frames.len(),
        params.method.label(),
        if args.gpu { "GPU" } else { "CPU" },
        args.out.display(),
        frame_times(&frame_ms)
    );
    Ok(())
}

/// The renderer's time per frame in words: the first frame apart (on the GPU it builds the
/// pipelines and buffers), then the median of the rest.
fn frame_times(frame_ms: &[f64]) -> String {
    match frame_ms {
        [] => "no frames".to_owned(),
        [only] => format!("{only:.0} ms in the renderer"),
        [first, rest @ ..] => {
            let mut rest = rest.to_vec();
            rest.sort_by(f64::total_cmp);
            format!("renderer: first frame {first:.0} ms, then {:.1} ms a frame (median)", rest[rest.len() / 2])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::frame_times;

    #[test]
    fn frame_times_keep_the_first_frame_apart_from_the_median_of_the_rest() {
        assert_eq!(frame_times(&[]), "no frames");
        assert_eq!(frame_times(&[12.4]), "12 ms in the renderer");
        assert_eq!(frame_times(&[900.0, 20.0, 18.0, 50.0]), "renderer: first frame 900 ms, then 20.0 ms a frame (median)");
    }
}
