//! `dynview synth`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use dynview_synth::SynthConfig;
use dynview_synth::rig::Layout;
use dynview_synth::unsync::UnsyncConfig;

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
    /// Add a small, fast, untextured ball and a plain-coloured box to the moving things
    /// (nothing on them for stereo to match; the held-out cameras' object ids name them).
    #[arg(long)]
    plain_movers: bool,
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
    /// How far the input cameras stand above and below the default height (m), alternately
    /// from camera to camera, as on a studio's dome.
    #[arg(long, value_name = "M", default_value_t = 0.0)]
    height_spread: f64,
    /// Unsynchronized cameras, as phones started by hand: each on its own clock, starting a
    /// different, non-whole-frame time (up to 0.8 s) before the event and stopping after it;
    /// camera 1 films at twice --fps, camera 2 at a variable frame rate, camera 3 in portrait
    /// (rotation metadata), camera 4's clock drifts (numbers modulo --cameras); every video gets
    /// the event's sound as heard at its camera. `input/<camera>/` then holds each camera's own
    /// frames; the true clocks go to synth.json's `time_alignment` and `unsync/<camera>.json`.
    #[arg(long)]
    unsync: bool,
    /// With --unsync: the unsynchronized recording as a JSON file of `UnsyncConfig` instead of
    /// the phones preset (per-camera `start_offsets_s`, `tail_s`, `fps`; `vfr_camera`,
    /// `vfr_jitter`, `portrait_camera`, `drift_camera`, `drift_ms_per_min`, `audio`, `noise_db`).
    #[arg(long, value_name = "FILE", requires = "unsync", conflicts_with_all = ["no_audio", "audio_noise_db", "drift_ms_per_min"])]
    unsync_config: Option<PathBuf>,
    /// With --unsync: videos without audio tracks.
    #[arg(long, requires = "unsync")]
    no_audio: bool,
    /// With --unsync: each camera's own microphone noise, this many dB below the event's sound.
    #[arg(long, value_name = "DB", requires = "unsync")]
    audio_noise_db: Option<f64>,
    /// With --unsync: how many ms the drifting camera's clock gains per minute (negative: loses).
    #[arg(long, value_name = "MS", requires = "unsync", allow_negative_numbers = true)]
    drift_ms_per_min: Option<f64>,
}

/// The unsynchronized recording the arguments ask for, if any.
fn unsync_config(args: &Args) -> anyhow::Result<Option<UnsyncConfig>> {
    if !args.unsync {
        return Ok(None);
    }
    if let Some(path) = &args.unsync_config {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let config = serde_json::from_str(&text).with_context(|| format!("{}: not an unsync configuration", path.display()))?;
        return Ok(Some(config));
    }
    let mut config = UnsyncConfig::phones(args.cameras, args.fps, args.seed);
    config.audio = !args.no_audio;
    config.noise_db = args.audio_noise_db.unwrap_or(config.noise_db);
    config.drift_ms_per_min = args.drift_ms_per_min.unwrap_or(config.drift_ms_per_min);
    Ok(Some(config))
}

/// Two comma-separated numbers of option `name`, when given.
fn pair(name: &str, values: Option<&[f64]>) -> anyhow::Result<Option<[f64; 2]>> {
    values.map(|v| <[f64; 2]>::try_from(v).map_err(|_| anyhow::anyhow!("{name} takes two numbers, as A,B; found {}", v.len()))).transpose()
}

/// Runs `dynview synth`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let unsync = unsync_config(&args)?;
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
            height_spread_m: args.height_spread,
        },
        unsync,
        plain_movers: args.plain_movers,
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
    if let Some(alignment) = &report.time_alignment {
        println!("unsynchronized cameras (video time of event time 0, clock rate, frames):");
        for (name, c) in &alignment.cameras {
            let kind = [(c.vfr, " variable rate"), (c.portrait, " portrait"), (c.rate != 1.0, " drifting")];
            let kind: String = kind.iter().filter(|(on, _)| *on).map(|(_, k)| *k).collect();
            println!("  {name}: start {:.4} s, rate {:.6}, {} frames at {} fps{kind}", c.start_s, c.rate, c.frame_count, c.fps);
        }
    }
    Ok(())
}
