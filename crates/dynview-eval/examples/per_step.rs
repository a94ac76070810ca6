//! Per time step PSNR of the full method along the synthetic event's moving held-out camera,
//! for each package given, rendered as a sequence (each frame the previous one of the next)
//! and each step alone, and each package's steps against the first's: where a change of
//! pipeline wins or loses. `cargo run --release -p dynview-eval --example per_step --
//! EVENT_DIR SCENE_DIR...` (the synthetic event as `dynview synth` writes it, then packages of
//! it; `SAVE_STEP=N` also writes step N's render of each package and its truth to `/tmp`).

use anyhow::Context;
use dynview_core::metrics::psnr;
use dynview_core::render::{Method, RenderHooks, RenderParams, StreamingRenderer};
use dynview_core::scene::ScenePackage;
use dynview_eval::eval::scoring::{load_sequence, render_sequence};

/// The per-step PSNRs (dB) of one package: rendered as a sequence, and each step alone.
struct Row {
    dir: String,
    streamed_db: Vec<f64>,
    alone_db: Vec<f64>,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let event = std::path::PathBuf::from(args.first().context("usage: per_step EVENT_DIR SCENE_DIR...")?);
    anyhow::ensure!(args.len() >= 2, "usage: per_step EVENT_DIR SCENE_DIR...");
    let save_step: Option<usize> = std::env::var("SAVE_STEP").ok().and_then(|s| s.parse().ok());
    let params = RenderParams { method: Method::Full, ..RenderParams::default() };
    let mut rows = Vec::new();
    for dir in &args[1..] {
        let package = ScenePackage::open(dir).with_context(|| format!("opening {dir}"))?;
        let steps = (package.time_step_count() as usize).min(30);
        let (path, truth) = load_sequence(&event, "camera_path.json", "heldout", steps)?;
        let inputs: Vec<_> = (0..steps as u32).map(|t| package.time_step_inputs(t, params.levels)).collect::<Result<_, _>>()?;
        let (streamed, _) = render_sequence(&params, &path, &inputs)?;
        let mut alone_db = Vec::with_capacity(steps);
        for t in 0..steps {
            let out = StreamingRenderer::new().render(&params, &path[t].camera, &inputs[t], &mut RenderHooks::default())?;
            if save_step == Some(t) {
                let tag = dir.replace('/', "_");
                out.color.to_rgb8().save(format!("/tmp/step{t}_{tag}.png"))?;
                truth[t].to_rgb8().save(format!("/tmp/step{t}_truth.png"))?;
            }
            alone_db.push(psnr(&out.color, &truth[t]));
        }
        let streamed_db = streamed.iter().zip(&truth).map(|((c, _), gt)| psnr(c, gt)).collect();
        rows.push(Row { dir: dir.clone(), streamed_db, alone_db });
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    for row in &rows {
        println!("{}: streamed {:.3} dB, alone {:.3} dB", row.dir, mean(&row.streamed_db), mean(&row.alone_db));
    }
    let base = &rows[0];
    for row in &rows[1..] {
        println!("\n{} against {}: step, streamed difference (dB), alone difference (dB)", row.dir, base.dir);
        for t in 0..row.streamed_db.len().min(base.streamed_db.len()) {
            println!("{t:3} {:+.3} {:+.3}", row.streamed_db[t] - base.streamed_db[t], row.alone_db[t] - base.alone_db[t]);
        }
    }
    Ok(())
}
