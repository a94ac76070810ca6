//! `cargo xtask eval`: the quality table of the renderer and its baselines on the synthetic
//! event's held-out cameras, written to `docs/results/`.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use anyhow::{Context, bail};
use dynview_core::render::{Method, TimeStepInputs};
use dynview_core::scene::ScenePackage;
use dynview_core::{RgbRaster, ScalarRaster};
use dynview_synth::SynthConfig;

use crate::datasets::sfm::layout_config;
use crate::eval::objects::{ObjectTruth, depth_errors_cell};
use crate::eval::pipeline::{TRUE_POSES, markdown_section, run as run_pipeline};
use crate::eval::scoring::{Options, Row, VIDEOS_DIR, evaluate_method, load_sequence};

/// The evaluation: renders, scores, and writes `eval.md` and `eval_strip.png` into
/// `options.out` when every method was run.
pub fn run(mut options: Options) -> anyhow::Result<()> {
    if options.unsync {
        return crate::eval::unsync_synthetic::run(&options);
    }
    if options.methods.is_empty() {
        options.methods = Method::ALL.to_vec();
    }
    if let Some(file) = &options.params_file {
        let text = fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
        options.params = serde_json::from_str(&text).with_context(|| format!("{}: not render parameters", file.display()))?;
    }
    let (event, config) = match &options.layout {
        None if options.plain_movers => {
            options.out = options.work_dir();
            (options.work_dir().join("event"), SynthConfig { plain_movers: true, ..SynthConfig::default() })
        }
        None => (options.work_dir().join("event"), SynthConfig::default()),
        Some(name) => {
            let (_, config) =
                layout_config(name).with_context(|| format!("unknown layout {name:?} (known: arc5x40, arc8x90, arc12x60)"))?;
            options.out = options.work_dir();
            (options.work_dir().join("event"), SynthConfig { videos: true, plain_movers: options.plain_movers, ..config })
        }
    };
    // The full pipeline starts from the videos: an event made without them is made again
    // (same seed, same ground truth).
    // So is one made before the held-out cameras' object ids were written.
    let stale = !event.join(dynview_synth::SYNTH_MARKER).is_file()
        || (options.pipeline && !event.join(VIDEOS_DIR).is_dir())
        || !event.join("heldout").join(dynview_synth::OBJECT_DIR).is_dir();
    if stale {
        if event.exists() {
            fs::remove_dir_all(&event).with_context(|| format!("cannot remove {}", event.display()))?;
        }
        println!("making the synthetic event (with videos) in {} ...", event.display());
        let summary = dynview_synth::generate(&config, &event, &|_, _, _| {})?;
        if options.pipeline && !summary.videos_written {
            bail!("the full-pipeline evaluation needs the event's videos: install ffmpeg, or pass --no-pipeline");
        }
    }
    let package = ScenePackage::open(event.join("scene"))?;
    let frames = options.frames.unwrap_or(package.time_step_count() as usize).min(package.time_step_count() as usize);
    let moving = load_sequence(&event, "camera_path.json", "heldout", frames)?;
    let still = load_sequence(&event, "camera_path_static.json", "heldout_static", frames)?;
    let objects = ObjectTruth::load(&event, "heldout", frames)?;
    let inputs: Vec<TimeStepInputs> =
        (0..frames as u32).map(|t| package.time_step_inputs(t, options.params.levels)).collect::<Result<_, _>>()?;

    let mut rows = Vec::new();
    let mut strips: Vec<(Method, RgbRaster, ScalarRaster)> = Vec::new();
    let strip_frame = frames / 2;
    for &method in &options.methods {
        let (row, moving_out) = evaluate_method(method, &options, &moving, &still, &inputs, &objects, 1.0)?;
        rows.push(row);
        let (c, d) = &moving_out[strip_frame];
        strips.push((method, c.clone(), d.clone()));
    }
    drop(inputs);
    let pipeline = if options.pipeline { Some(run_pipeline(&event, &package, &options, &moving, &still, &objects, frames)?) } else { None };
    if let Some(variants) = &pipeline {
        let full = |label: &str| {
            variants.iter().find(|v| v.label == label).and_then(|v| v.rows.iter().find(|r| r.method == Method::Full)).map(|r| r.psnr_moving)
        };
        if let (Some(ours), Some(truth)) = (full("densified"), full(TRUE_POSES)) {
            println!(
                "{}: full method {truth:.2} dB from prep on the true poses, {ours:.2} dB on our own: {:+.2} dB",
                options.layout.as_deref().unwrap_or("event"),
                ours - truth
            );
        }
    }
    if options.methods.len() != Method::ALL.len() {
        return Ok(());
    }
    let labels: Vec<&str> = objects.moving.iter().map(|o| o.label.as_str()).collect();
    let mut table = markdown_table(&rows, frames, &config, &labels);
    if let Some(variants) = &pipeline {
        table.push_str(&markdown_section(variants, &rows, frames));
    }
    println!("\n{table}");
    fs::create_dir_all(&options.out)?;
    dynview_core::fsutil::write_atomic(&options.out.join("eval.md"), table.as_bytes())?;
    write_strip(&options.out.join("eval_strip.png"), &moving.1[strip_frame], &strips)?;
    println!("wrote {} and {}", options.out.join("eval.md").display(), options.out.join("eval_strip.png").display());
    Ok(())
}

fn markdown_table(rows: &[Row], frames: usize, config: &SynthConfig, moving_objects: &[&str]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Renderer evaluation on the synthetic event\n");
    let _ = writeln!(
        s,
        "`dynview synth` defaults{} ({} cameras, {} frames used of {}, {}x{}, seed {}): ground-truth scene package (clouds: {:.1}% of pixels per camera, {} mm noise, {:.0}% outliers). \
         PSNR and SSIM on the moving held-out camera, averaged over frames; flicker on the static held-out camera: mean absolute frame-to-frame change of the output on pixels whose \
         ground truth changes by less than 2/255, minus the same for the ground truth (lower is better). Depth error: on the pixels of each moving object ({}) as the moving \
         held-out camera sees them, the median of |rendered - true| / true over every frame (a pixel without depth counts 100%). Time: this machine, all cores, per frame including sparse projection.\n",
        if config.plain_movers {
            " with `--plain-movers` (a small, fast, untextured ball and a plain-coloured box among the moving things)"
        } else {
            ""
        },
        config.cameras,
        frames,
        config.frames,
        config.width,
        config.height,
        config.seed,
        config.point_fraction * 100.0,
        config.point_noise_m * 1000.0,
        config.outlier_fraction * 100.0,
        moving_objects.join(", ")
    );
    let _ =
        writeln!(s, "| method | PSNR (dB) | SSIM | static PSNR (dB) | flicker (x1000) | depth error on moving objects (%) | ms/frame |");
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    for (r, letter) in rows.iter().zip(["a", "b", "c", "d", "e"]) {
        let _ = writeln!(
            s,
            "| ({letter}) {} | {:.2} | {:.4} | {:.2} | {:.3} | {} | {:.0} |",
            r.method.label(),
            r.psnr_moving,
            r.ssim_moving,
            r.psnr_static,
            r.flicker_static * 1000.0,
            depth_errors_cell(&r.moving_object_depth_pct),
            r.ms_per_frame
        );
    }
    let _ = writeln!(
        s,
        "\nReproduce: `cargo xtask eval` (strip: `docs/results/eval_strip.png`: ground truth, (c) blend, (e) full, depth of (e))."
    );
    s
}

fn write_strip(path: &Path, truth: &RgbRaster, renders: &[(Method, RgbRaster, ScalarRaster)]) -> anyhow::Result<()> {
    let pick = |m: Method| renders.iter().find(|(rm, _, _)| *rm == m).context("method missing");
    let (_, blend, _) = pick(Method::Blend)?;
    let (_, full, full_depth) = pick(Method::Full)?;
    let panels = [truth.clone(), blend.clone(), full.clone(), dynview_core::display::colorize_depth(full_depth)];
    let (w, h) = (truth.width / 2, truth.height / 2);
    let mut strip = image::RgbImage::new(w as u32 * panels.len() as u32, h as u32);
    for (k, panel) in panels.iter().enumerate() {
        let small = image::imageops::resize(&panel.to_rgb8(), w as u32, h as u32, image::imageops::FilterType::Triangle);
        image::imageops::replace(&mut strip, &small, (k * w) as i64, 0);
    }
    let mut bytes = Vec::new();
    strip.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)?;
    dynview_core::fsutil::write_atomic(path, &bytes)?;
    Ok(())
}
