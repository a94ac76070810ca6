//! `dynview synth`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use dynview_synth::SynthConfig;
use dynview_synth::rig::Layout;

use crate::progress::StageBars;

/// Arguments of `dynview synth`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder (created; an earlier synth output there is replaced when done).
    #[arg(long)]
    out: PathBuf,
    /// Number of input cameras (on a 60-degree arc).
    #[arg(long, default_value_t = SynthConfig::default().cameras)]
    cameras: usize,
    /// Number of frames.
    #[arg(long, default_value_t = SynthConfig::default().frames)]
    frames: u32,
    /// Frame width in pixels.
    #[arg(long, default_value_t = SynthConfig::default().width)]
    width: u32,
    /// Frame height in pixels.
    #[arg(long, default_value_t = SynthConfig::default().height)]
    height: u32,
    /// Seed of textures, hand-held wobble and point sampling.
    #[arg(long, default_value_t = SynthConfig::default().seed)]
    seed: u64,
    /// Hand-held input cameras (smooth wobble).
    #[arg(long)]
    handheld: bool,
    /// Frames per second.
    #[arg(long, default_value_t = SynthConfig::default().fps)]
    fps: f64,
    /// Color samples per pixel along each axis (anti-aliasing).
    #[arg(long, default_value_t = SynthConfig::default().supersample)]
    supersample: u32,
    /// Share of each input frame's pixels sampled into the ground-truth clouds.
    #[arg(long, default_value_t = SynthConfig::default().point_fraction)]
    point_fraction: f64,
    /// Standard deviation of cloud point noise in metres.
    #[arg(long, default_value_t = SynthConfig::default().point_noise_m)]
    point_noise: f64,
    /// Share of outliers in the clouds.
    #[arg(long, default_value_t = SynthConfig::default().outlier_fraction)]
    outliers: f64,
    /// Do not write videos even when ffmpeg is installed.
    #[arg(long)]
    no_video: bool,
    /// Total angle spanned by the input cameras (degrees).
    #[arg(long, default_value_t = dynview_synth::rig::ARC_DEG)]
    arc_deg: f64,
    /// Focal lengths as multiples of the longer image side, first camera to last, as `A,B`
    /// (default: every camera a 42-degree vertical field of view).
    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "A,B")]
    focal_range: Option<Vec<f64>>,
    /// Offset of the true principal points from the image centre in px, as `DX,DY`; the sign
    /// alternates from camera to camera.
    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "DX,DY", default_value = "0,0")]
    principal_offset: Vec<f64>,
}

/// Two comma-separated numbers of option `name`, when given.
fn pair(name: &str, values: Option<&[f64]>) -> anyhow::Result<Option<[f64; 2]>> {
    values.map(|v| <[f64; 2]>::try_from(v).map_err(|_| anyhow::anyhow!("{name} takes two numbers, as A,B; found {}", v.len()))).transpose()
}

/// Runs `dynview synth`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = SynthConfig {
        cameras: args.cameras,
        frames: args.frames,
        width: args.width,
        height: args.height,
        fps: args.fps,
        seed: args.seed,
        handheld: args.handheld,
        supersample: args.supersample,
        point_fraction: args.point_fraction,
        point_noise_m: args.point_noise,
        outlier_fraction: args.outliers,
        videos: !args.no_video,
        layout: Layout {
            arc_deg: args.arc_deg,
            focal_range: pair("--focal-range", args.focal_range.as_deref())?,
            principal_offset_px: pair("--principal-offset", Some(&args.principal_offset))?.unwrap_or_default(),
        },
    };
    let start = Instant::now();
    let bars = StageBars::new();
    let report = dynview_synth::generate(&config, &args.out, &|stage, done, total| bars.update(stage, done, total))
        .with_context(|| format!("generating the synthetic event in {}", args.out.display()))?;
    bars.finish();
    let points: u64 = report.points_per_step.iter().map(|&n| u64::from(n)).sum();
    println!(
        "wrote {} ({} cameras + held-out, {} frames of {}x{}) in {:.1} s",
        args.out.display(),
        config.cameras,
        config.frames,
        config.width,
        config.height,
        start.elapsed().as_secs_f64()
    );
    println!(
        "scene package {}: {:.2} MiB, {points} points; videos: {}",
        args.out.join("scene").display(),
        report.package_bytes as f64 / (1024.0 * 1024.0),
        if report.videos_written { "written" } else { "skipped (no ffmpeg or --no-video)" }
    );
    Ok(())
}
