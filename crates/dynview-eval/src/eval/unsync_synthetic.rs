//! `cargo xtask eval --unsync`: the synthetic event filmed by unsynchronized phones
//! ([`dynview_synth::unsync::UnsyncConfig::phones`]: start offsets that are not whole frames, a
//! 60 fps camera, a variable rate, a portrait phone, a drifting clock, a sound track each), put
//! on one timeline by `dynview prep` from the pictures and from the sound. Each camera's clock
//! is compared with the truth, and the moving held-out camera is rendered from each package and
//! scored against the package `prep` makes from the synchronized event (same seed, same
//! scene, the same true poses). The package's first step is put at event time 0 with
//! `--start-at` (the moment, not the offsets, taken from the truth), so that the held-out
//! camera's frames line up. Results in `docs/results/unsync_synthetic.md`.

use std::fmt::Write as _;
use std::fs;

use anyhow::Context;
use dynview_core::metrics::psnr;
use dynview_core::render::{Method, RenderParams, TimeStepInputs};
use dynview_core::scene::ScenePackage;
use dynview_synth::unsync::{TimeAlignment, UnsyncConfig};
use dynview_synth::{SYNTH_MARKER, SynthConfig, SynthReport};
use serde::Deserialize;

use crate::eval::scoring::{Options, VIDEOS_DIR, load_sequence, render_sequence};
use crate::runs::prep::{prep_args_suffix, prep_once};
use crate::runs::programs::dynview_binary;

#[derive(Deserialize)]
struct Report {
    time_alignment: Found,
}

#[derive(Deserialize)]
struct Found {
    method: String,
    cameras: std::collections::BTreeMap<String, FoundCamera>,
}

#[derive(Deserialize)]
struct FoundCamera {
    start_s: f64,
    rate: f64,
    confidence: f64,
}

/// One way of aligning: the clocks' errors and the held-out PSNR.
struct Row {
    method: String,
    /// Per camera: name, error of the first step's moment (ms), rate found, true rate, confidence.
    cameras: Vec<(String, f64, f64, f64, f64)>,
    psnr_db: f64,
    steps: usize,
}

/// The evaluation: writes `unsync_synthetic.md` into `options.out`.
pub fn run(options: &Options) -> anyhow::Result<()> {
    let root = options.work_dir();
    let config = SynthConfig::default();
    let event = root.join("event");
    let unsync_event = root.join("event-unsync");
    let synchronized_phones = root.join("event-phones-synchronized");
    let phones = UnsyncConfig::phones(config.cameras, config.fps, config.seed);
    let phones_in_sync = UnsyncConfig { audio: false, ..phones.synchronized(config.fps) };
    for (dir, unsync) in [(&event, None), (&unsync_event, Some(phones)), (&synchronized_phones, Some(phones_in_sync))] {
        if !dir.join(SYNTH_MARKER).is_file() || !dir.join(VIDEOS_DIR).is_dir() {
            if dir.exists() {
                fs::remove_dir_all(dir).with_context(|| format!("cannot remove {}", dir.display()))?;
            }
            println!("making {} ...", dir.display());
            dynview_synth::generate(&SynthConfig { unsync, ..config.clone() }, dir, &|_, _, _| {})?;
        }
    }
    let text = fs::read_to_string(unsync_event.join(SYNTH_MARKER))?;
    let synth: SynthReport = serde_json::from_str(&text).context("synth.json")?;
    let truth = synth.time_alignment.context("the unsynchronized event has no time_alignment")?;
    let first = truth.cameras.keys().next().context("no cameras")?.clone();
    let dynview = dynview_binary()?;
    let frames = options.frames.unwrap_or(config.frames as usize).min(config.frames as usize);
    let moving = load_sequence(&event, "camera_path.json", "heldout", frames)?;
    let params = RenderParams { method: Method::Full, ..options.params.clone() };
    let score = |package: &ScenePackage| -> anyhow::Result<(f64, usize)> {
        let steps = frames.min(package.time_step_count() as usize);
        let inputs: Vec<TimeStepInputs> =
            (0..steps as u32).map(|t| package.time_step_inputs(t, params.levels)).collect::<Result<_, _>>()?;
        let (out, _) = render_sequence(&params, &moving.0[..steps], &inputs)?;
        let mean = out.iter().zip(&moving.1).map(|((c, _), truth)| psnr(c, truth)).sum::<f64>() / steps.max(1) as f64;
        Ok((mean, steps))
    };
    // `--prep-arg`s go to every run, each then in a folder of its own.
    let suffix = prep_args_suffix(&options.prep_args);
    let folder = |name: &str| root.join(format!("{name}{suffix}"));
    let control_args = [vec!["--poses".to_string(), event.join("colmap").display().to_string()], options.prep_args.clone()].concat();
    let control = prep_once(&dynview, &event.join(VIDEOS_DIR), &folder("prep-true-poses"), &control_args, options.fresh)?;
    let (control_psnr, control_steps) = score(&ScenePackage::open(control.scene_dir())?)?;
    let mut rows =
        vec![Row { method: "the rig, synchronized (no phones)".into(), cameras: Vec::new(), psnr_db: control_psnr, steps: control_steps }];
    let offsets = |truth: &TimeAlignment| -> Vec<String> {
        truth.cameras.iter().flat_map(|(name, c)| ["--offsets".to_string(), format!("{name}={}", c.start_s)]).collect()
    };
    // A phones event prepared with its true poses, `--fps`, the first step where `truth` puts
    // event time 0, and the clocks as `sync` finds or gives them.
    let phones_args = |event: &std::path::Path, truth: &TimeAlignment, sync: Vec<String>| -> Vec<String> {
        let start = format!("{first}={}", truth.cameras[&first].start_s);
        let colmap = event.join("colmap").display().to_string();
        let mut args: Vec<String> =
            ["--poses", &colmap, "--fps", &config.fps.to_string(), "--start-at", &start].iter().map(|s| s.to_string()).collect();
        args.extend(sync);
        args.extend(options.prep_args.iter().cloned());
        args
    };
    // The control: the same phones (a portrait one sees another part of the scene), started on
    // whole frames, without variable rate or drift: what timing alone costs is the difference.
    let text = fs::read_to_string(synchronized_phones.join(SYNTH_MARKER))?;
    let in_sync: SynthReport = serde_json::from_str(&text).context("synth.json")?;
    let in_sync = in_sync.time_alignment.context("the synchronized phones have no time_alignment")?;
    let args = phones_args(&synchronized_phones, &in_sync, offsets(&in_sync));
    let run = prep_once(&dynview, &synchronized_phones.join(VIDEOS_DIR), &folder("prep-phones-synchronized"), &args, options.fresh)?;
    let (psnr_db, steps) = score(&ScenePackage::open(run.scene_dir())?)?;
    rows.push(Row { method: "the same phones, synchronized (control)".into(), cameras: Vec::new(), psnr_db, steps });
    // The true clocks given by hand first: what the phones' own timing costs, alignment aside.
    let true_offsets = offsets(&truth);
    let nearest = [true_offsets.clone(), vec!["--retime".into(), "nearest".into()]].concat();
    for (label, sync) in [
        ("given-nearest", nearest),
        ("given", true_offsets),
        ("visual", vec!["--sync".into(), "visual".into()]),
        ("audio", vec!["--sync".into(), "audio".into()]),
    ] {
        let args = phones_args(&unsync_event, &truth, sync);
        let run = prep_once(&dynview, &unsync_event.join(VIDEOS_DIR), &folder(&format!("prep-unsync-{label}")), &args, options.fresh)?;
        let report: Report = serde_json::from_str(&fs::read_to_string(run.out.join("report.json"))?).context("report.json")?;
        let (psnr_db, steps) = score(&ScenePackage::open(run.scene_dir())?)?;
        let method = match label {
            "given-nearest" => "true clocks given, nearest frames (--retime nearest)".to_string(),
            "given" => "true clocks given (--offsets)".to_string(),
            _ => report.time_alignment.method.clone(),
        };
        rows.push(Row { method, cameras: clock_errors(&report.time_alignment, &truth), psnr_db, steps });
    }
    let table = markdown(&rows, &truth);
    println!("\n{table}");
    fs::create_dir_all(&options.out)?;
    let path = options.out.join("unsync_synthetic.md");
    dynview_core::fsutil::write_atomic(&path, table.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Per camera, how far (ms) from the others its clock puts the first time step, by its true
/// clock, with the rate found, the true rate and the confidence.
fn clock_errors(found: &Found, truth: &TimeAlignment) -> Vec<(String, f64, f64, f64, f64)> {
    let moments: Vec<(String, f64)> = found
        .cameras
        .iter()
        .filter_map(|(name, f)| truth.cameras.get(name).map(|t| (name.clone(), (f.start_s - t.start_s) / t.rate)))
        .collect();
    let mut sorted: Vec<f64> = moments.iter().map(|(_, m)| *m).collect();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    moments
        .into_iter()
        .map(|(name, moment)| {
            let (f, t) = (&found.cameras[&name], &truth.cameras[&name]);
            (name, (moment - median) * 1e3, f.rate, t.rate, f.confidence)
        })
        .collect()
}

fn markdown(rows: &[Row], truth: &TimeAlignment) -> String {
    let mut s = String::from("# Unsynchronized phones on the synthetic event\n\n");
    let roles: Vec<String> = truth
        .cameras
        .iter()
        .map(|(name, c)| {
            let mut role = format!("{name} {} fps", c.fps);
            if c.vfr {
                role.push_str(" variable");
            }
            if c.portrait {
                role.push_str(" portrait");
            }
            if (c.rate - 1.0).abs() > 1e-9 {
                let _ = write!(role, " drifting {:+.1} ms/min", (c.rate - 1.0) * 60_000.0);
            }
            let _ = write!(role, ", starts {:.4} s", c.start_s);
            role
        })
        .collect();
    let _ = writeln!(
        s,
        "The default synthetic event (`SynthConfig::default()`) filmed by the phones preset of `dynview synth --unsync`: {}. \
         Prepared with the true poses, `--fps 30`, `--start-at` the first camera's video time of event time 0, and the clocks \
         as in the row (the true ones given with `--offsets`, or found by `--sync`); each step's frame of a camera that did \
         not film at its moment made from the frames around it (`--retime flow`, the default) unless the row says nearest \
         frames. The control is the same phones synchronized (`UnsyncConfig::synchronized`: each start on a whole frame, \
         no variable rate, no drift; its portrait phone sees another part of the scene than the rig's camera), prepared \
         alike with its true clocks; the rig's synchronized event (the synthetic evaluation's) is shown above it. Clock error: how far from the \
         other cameras (median) a camera's clock puts the first time step, by its true clock. Full method, PSNR of the moving \
         held-out camera. Reproduce: `cargo xtask eval --unsync` (`--fresh` to prepare again).\n",
        roles.join("; ")
    );
    let _ = writeln!(s, "| alignment | worst clock error (ms) | worst (frames) | held-out PSNR (dB) | against the control (dB) | steps |");
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | ---: |");
    let control = rows.get(1).map_or(f64::NAN, |r| r.psnr_db);
    for r in rows {
        let worst = r.cameras.iter().map(|c| c.1.abs()).fold(0.0, f64::max);
        let _ = writeln!(
            s,
            "| {} | {worst:.2} | {:.3} | {:.2} | {:+.2} | {} |",
            r.method,
            worst * 30.0 / 1e3,
            r.psnr_db,
            r.psnr_db - control,
            r.steps
        );
    }
    for r in rows.iter().filter(|r| !r.cameras.is_empty()) {
        let cells: Vec<String> = r
            .cameras
            .iter()
            .map(|(name, error_ms, rate, true_rate, confidence)| {
                format!("{name} {error_ms:+.2} ms, rate {rate:.6} (true {true_rate:.6}), conf. {confidence:.2}")
            })
            .collect();
        let _ = writeln!(s, "\n{}: {}", r.method, cells.join("; "));
    }
    s
}
