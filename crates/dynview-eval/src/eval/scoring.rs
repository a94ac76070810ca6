//! What both halves of `cargo xtask eval` share (the rows from the ground-truth package in
//! [`super::synthetic`], those from `dynview prep`'s packages in [`super::pipeline`]): the
//! options, the held-out sequences, and one method rendered along them and scored.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use dynview_core::metrics::{flicker, psnr, ssim};
use dynview_core::render::{Method, RenderHooks, RenderParams, StreamingRenderer, TimeStepInputs};
use dynview_core::{RgbRaster, ScalarRaster};
use dynview_interchange::camera_path::{PathFrame, parse_path};

use crate::eval::objects::{ObjectTruth, depth_errors_cell};
use crate::paths::{results_dir, workspace_root};

/// Options of `dynview-eval eval` (`cargo xtask eval`): the synthetic event.
#[derive(Debug, clap::Args)]
pub struct Options {
    /// Time steps used (all when not given).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Methods compared, comma-separated (default: all; the tables are written only then).
    #[arg(long, value_delimiter = ',', value_parser = parse_method)]
    pub methods: Vec<Method>,
    /// Print the PSNR of every frame.
    #[arg(long)]
    pub verbose: bool,
    /// Render parameters as JSON (the method is set per row).
    #[arg(long = "params", value_name = "FILE")]
    pub params_file: Option<PathBuf>,
    /// Render parameters: the defaults, or `--params`' (read by [`super::synthetic::run`]).
    #[arg(skip)]
    pub params: RenderParams,
    /// Folder of the written results.
    #[arg(long, default_value_os_t = results_dir())]
    pub out: PathBuf,
    /// Skip the full pipeline (`dynview prep` on the event's videos).
    #[arg(long = "no-pipeline", action = clap::ArgAction::SetFalse)]
    pub pipeline: bool,
    /// Redo the pipeline's prep runs even when their packages exist.
    #[arg(long)]
    pub fresh: bool,
    /// Evaluate a synthetic layout of `bench sfm` (`arc5x40`, `arc8x90`, `arc12x60`: per-camera
    /// lenses, true principal points off the centre) instead of the default event; its event,
    /// prep runs and tables go to `target/eval/<layout>/`.
    #[arg(long)]
    pub layout: Option<String>,
    /// Evaluate the default event with a small, fast, untextured ball and a plain-coloured box
    /// added (`dynview synth --plain-movers`) instead; its event, prep runs and tables go to
    /// `target/eval/plain-movers/`. With `--layout`, the layout's hand-held event with them
    /// (`target/eval/<layout>-plain-movers/`).
    #[arg(long)]
    pub plain_movers: bool,
    /// An extra argument for the pipeline's `dynview prep` runs on our own poses, and with
    /// `--unsync` for every run (repeatable; e.g. `--prep-arg=--centred-principal-point`). Those
    /// runs then work in folders of their own, named after the arguments.
    #[arg(long = "prep-arg", allow_hyphen_values = true)]
    pub prep_args: Vec<String>,
    /// Instead of the tables: the event filmed by unsynchronized phones, aligned by prep from
    /// the pictures and from the sound, against the synchronized event
    /// (`unsync_synthetic.md`).
    #[arg(long)]
    pub unsync: bool,
}

impl Options {
    /// Where this evaluation's event and prep runs live.
    pub fn work_dir(&self) -> PathBuf {
        let root = workspace_root().join("target/eval");
        match &self.layout {
            Some(layout) if self.plain_movers => root.join(format!("{layout}-{PLAIN_MOVERS_DIR}")),
            Some(layout) => root.join(layout),
            None if self.plain_movers => root.join(PLAIN_MOVERS_DIR),
            None => root,
        }
    }
}

/// A method by its name in render parameters (`full`, `blend`, ...).
fn parse_method(name: &str) -> Result<Method, String> {
    serde_json::from_value(serde_json::Value::String(name.to_owned())).map_err(|_| format!("unknown method {name:?}"))
}

/// One row of the table.
pub struct Row {
    /// The method.
    pub method: Method,
    /// Mean PSNR on the moving held-out camera, dB.
    pub psnr_moving: f64,
    /// Mean SSIM on the moving held-out camera.
    pub ssim_moving: f64,
    /// Mean PSNR on the static held-out camera, dB.
    pub psnr_static: f64,
    /// Flicker on the static held-out camera (see the table's caption).
    pub flicker_static: f64,
    /// Milliseconds per frame of the moving sequence.
    pub ms_per_frame: f64,
    /// Per moving object of the event ([`ObjectTruth::moving`]), the median relative error of
    /// the depth rendered on its pixels of the moving held-out camera, %.
    pub moving_object_depth_pct: Vec<f64>,
}

/// A held-out camera path and its ground-truth images.
pub type Sequence = (Vec<PathFrame>, Vec<RgbRaster>);

/// Work folder (under `target/eval`) of the event with plain movers.
pub const PLAIN_MOVERS_DIR: &str = "plain-movers";

/// Subfolder of a synthetic event with its videos.
pub const VIDEOS_DIR: &str = "videos";

/// Renders both held-out sequences with `method` and scores them; returns the row and the
/// moving sequence's outputs (color, depth). The depth on the moving objects is scored against
/// `objects` (the moving held-out camera's), times `truth_per_rendered` (1 where the package is
/// in the true world).
pub fn evaluate_method(
    method: Method,
    options: &Options,
    moving: &Sequence,
    still: &Sequence,
    inputs: &[TimeStepInputs],
    objects: &ObjectTruth,
    truth_per_rendered: f64,
) -> anyhow::Result<(Row, Vec<(RgbRaster, ScalarRaster)>)> {
    let params = RenderParams { method, ..options.params.clone() };
    let (moving_out, ms) = render_sequence(&params, &moving.0, inputs)?;
    let (static_out, _) = render_sequence(&params, &still.0, inputs)?;
    let mean = |v: Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
    if options.verbose {
        let per_frame = |out: &[(RgbRaster, ScalarRaster)], truth: &[RgbRaster]| {
            out.iter().zip(truth).map(|((c, _), gt)| format!("{:.1}", psnr(c, gt))).collect::<Vec<_>>().join(" ")
        };
        println!("{} moving: {}", method.label(), per_frame(&moving_out, &moving.1));
        println!("{} static: {}", method.label(), per_frame(&static_out, &still.1));
    }
    let colors: Vec<RgbRaster> = static_out.iter().map(|(c, _)| c.clone()).collect();
    let row = Row {
        method,
        psnr_moving: mean(moving_out.iter().zip(&moving.1).map(|((c, _), gt)| psnr(c, gt)).collect()),
        ssim_moving: mean(moving_out.iter().zip(&moving.1).map(|((c, _), gt)| ssim(c, gt)).collect()),
        psnr_static: mean(static_out.iter().zip(&still.1).map(|((c, _), gt)| psnr(c, gt)).collect()),
        flicker_static: flicker(&colors, &still.1).unwrap_or(f64::NAN),
        ms_per_frame: ms,
        moving_object_depth_pct: objects.depth_errors_pct(&moving_out.iter().map(|(_, d)| d).collect::<Vec<_>>(), truth_per_rendered),
    };
    let objects_shown = if row.moving_object_depth_pct.is_empty() {
        String::new()
    } else {
        format!("  moving objects' depth error {} %", depth_errors_cell(&row.moving_object_depth_pct))
    };
    println!(
        "{:<12} PSNR {:.2} dB  SSIM {:.4}  static PSNR {:.2} dB  flicker {:.5}  {:.0} ms/frame{objects_shown}",
        method.label(),
        row.psnr_moving,
        row.ssim_moving,
        row.psnr_static,
        row.flicker_static,
        row.ms_per_frame
    );
    Ok((row, moving_out))
}

/// Renders `path` frame by frame (time step = index) with a streaming renderer; returns the
/// outputs and the mean milliseconds per frame.
pub fn render_sequence(
    params: &RenderParams,
    path: &[PathFrame],
    inputs: &[TimeStepInputs],
) -> anyhow::Result<(Vec<(RgbRaster, ScalarRaster)>, f64)> {
    let mut renderer = StreamingRenderer::new();
    let mut out = Vec::new();
    let start = Instant::now();
    for (t, frame) in path.iter().enumerate() {
        let output = renderer.render(params, &frame.camera, &inputs[t], &mut RenderHooks::default())?;
        out.push((output.color, output.depth));
    }
    Ok((out, start.elapsed().as_secs_f64() * 1000.0 / path.len().max(1) as f64))
}

/// The held-out path `path_file` of `event` and its first `frames` ground-truth frames.
pub fn load_sequence(event: &Path, path_file: &str, folder: &str, frames: usize) -> anyhow::Result<Sequence> {
    let path = parse_path(&fs::read(event.join(path_file))?, path_file, None)?;
    let truth = (0..frames)
        .map(|t| {
            let file = event.join(folder).join("color").join(format!("{t:05}.png"));
            let img = image::open(&file).with_context(|| format!("reading {}", file.display()))?;
            Ok(RgbRaster::from_rgb8(&img.to_rgb8()))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok((path.into_iter().take(frames).collect(), truth))
}
