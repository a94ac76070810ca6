//! `dynview render` as a user runs it.

use std::fs;
use std::path::Path;
use std::process::Command;

fn dynview(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynview")).args(args).output().expect("run dynview");
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

/// `dynview synth` of a small event without videos into `event`; panics with the log on failure.
fn synth(event: &Path, cameras: u32, frames: u32, width: u32, height: u32) {
    let numbers = [cameras, frames, width, height].map(|n| n.to_string());
    let (ok, log) = dynview(&[
        "synth",
        "--out",
        event.to_str().unwrap(),
        "--cameras",
        &numbers[0],
        "--frames",
        &numbers[1],
        "--width",
        &numbers[2],
        "--height",
        &numbers[3],
        "--no-video",
    ]);
    assert!(ok, "{log}");
}

/// `dynview render --scene event/scene --path path --out out` with `extra` arguments.
fn render(event: &Path, path: &Path, out: &Path, extra: &[&str]) -> (bool, String) {
    let scene = event.join("scene");
    let mut args = vec!["render", "--scene", scene.to_str().unwrap(), "--path", path.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    dynview(&args)
}

#[test]
fn render_writes_color_depth_and_scale_for_every_path_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    synth(&event, 4, 3, 96, 54);
    let out = tmp.path().join("render");
    let (ok, log) = render(&event, &event.join("camera_path.json"), &out, &["--width", "64", "--height", "36"]);
    assert!(ok, "{log}");
    for i in 0..3 {
        let color = image::open(out.join(format!("{i:05}.png"))).unwrap();
        assert_eq!((color.width(), color.height()), (64, 36));
        let depth = image::open(out.join(format!("depth/{i:05}.png"))).unwrap();
        assert!(matches!(depth, image::DynamicImage::ImageLuma16(_)), "depth must be 16-bit");
    }
    let scale: serde_json::Value = serde_json::from_str(&fs::read_to_string(out.join("depth/scale.json")).unwrap()).unwrap();
    assert!(scale["meters_per_unit"].as_f64().unwrap() > 0.0);

    // Baselines by flag, and parameters from a file.
    let params = tmp.path().join("params.json");
    fs::write(&params, r#"{"lambda_t": 0.02, "levels": 3}"#).unwrap();
    let (ok, log) = render(&event, &event.join("camera_path.json"), &tmp.path().join("blend"), &["--method", "blend"]);
    assert!(ok, "{log}");
    assert!(log.contains("blend"), "{log}");
    let (ok, log) = render(
        &event,
        &event.join("camera_path_static.json"),
        &tmp.path().join("p"),
        &["--params", params.to_str().unwrap(), "--no-temporal"],
    );
    assert!(ok, "{log}");
    assert!(log.contains("no-temporal"), "{log}");
}

#[test]
fn render_rejects_bad_paths_and_parameters_clearly() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    synth(&event, 2, 1, 32, 18);
    let out = tmp.path().join("o");
    let bad_path = tmp.path().join("path.json");
    fs::write(
        &bad_path,
        r#"{"render_height": 10, "render_width": 20, "camera_path": [{"camera_to_world": [1,0,0], "fov": 50, "aspect": 1}]}"#,
    )
    .unwrap();
    let (ok, log) = render(&event, &bad_path, &out, &[]);
    assert!(!ok);
    assert!(log.contains("camera_path[0].camera_to_world"), "{log}");
    let params = tmp.path().join("params.json");
    fs::write(&params, r#"{"lamda_t": 0.1}"#).unwrap();
    let (ok, log) = render(&event, &event.join("camera_path.json"), &out, &["--params", params.to_str().unwrap()]);
    assert!(!ok);
    assert!(log.contains("lamda_t"), "{log}");
    let (ok, log) = render(&event, &event.join("camera_path.json"), &out, &["--method", "magic"]);
    assert!(!ok);
    assert!(log.contains("unknown method"), "{log}");
}

#[test]
fn render_on_the_gpu_matches_the_cpu_render() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    synth(&event, 4, 3, 96, 54);
    let path = event.join("camera_path.json");
    let (cpu_dir, gpu_dir) = (tmp.path().join("cpu"), tmp.path().join("gpu"));
    let (ok, log) = render(&event, &path, &cpu_dir, &[]);
    assert!(ok, "{log}");
    let (ok, log) = render(&event, &path, &gpu_dir, &["--gpu"]);
    assert!(ok, "{log}");
    assert!(log.contains("on the GPU"), "{log}");
    for i in 0..3 {
        let a = image::open(cpu_dir.join(format!("{i:05}.png"))).unwrap().to_rgb8();
        let b = image::open(gpu_dir.join(format!("{i:05}.png"))).unwrap().to_rgb8();
        // The parity tolerance of the GPU renderer: PSNR >= 45 dB, mean absolute difference
        // <= 1/255 (here on 8-bit outputs).
        let n = a.as_raw().len() as f64;
        let mad = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| f64::from(x.abs_diff(*y))).sum::<f64>() / n;
        let mse = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| f64::from(x.abs_diff(*y)).powi(2)).sum::<f64>() / n;
        let db = if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0f64.powi(2) / mse).log10() };
        assert!(db >= 45.0 && mad <= 1.0, "frame {i}: GPU vs CPU {db:.1} dB, mean abs difference {mad:.3}/255");
    }
    // Baselines stay on the CPU, and say so.
    let (ok, log) = render(&event, &path, &tmp.path().join("x"), &["--gpu", "--method", "blend"]);
    assert!(!ok && log.contains("runs on the CPU"), "{log}");
}

#[test]
fn a_frame_that_cannot_be_written_is_an_error_naming_it_and_the_others_are_written() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    synth(&event, 2, 3, 32, 18);
    let out = tmp.path().join("o");
    // A folder where the second frame's PNG goes: the frames are written beside the rendering,
    // and that one fails.
    fs::create_dir_all(out.join("00001.png").join("taken")).unwrap();
    let (ok, log) = render(&event, &event.join("camera_path.json"), &out, &[]);
    assert!(!ok, "{log}");
    assert!(log.contains("00001.png"), "{log}");
    assert!(out.join("00000.png").is_file() && out.join("depth/00000.png").is_file(), "the first frame is written");
    assert!(out.join("00001.png").join("taken").is_dir(), "what was there is kept");
}
