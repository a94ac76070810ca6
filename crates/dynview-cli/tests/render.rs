//! `dynview render` as a user runs it.

use std::fs;
use std::process::Command;

fn dynview(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynview")).args(args).output().expect("run dynview");
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

#[test]
fn render_writes_color_depth_and_scale_for_every_path_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    let e = event.to_str().unwrap();
    let (ok, log) = dynview(&["synth", "--out", e, "--cameras", "4", "--frames", "3", "--width", "96", "--height", "54", "--no-video"]);
    assert!(ok, "{log}");
    let out = tmp.path().join("render");
    let (ok, log) = dynview(&[
        "render",
        "--scene",
        event.join("scene").to_str().unwrap(),
        "--path",
        event.join("camera_path.json").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "36",
    ]);
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
    let (ok, log) = dynview(&[
        "render",
        "--scene",
        event.join("scene").to_str().unwrap(),
        "--path",
        event.join("camera_path.json").to_str().unwrap(),
        "--out",
        tmp.path().join("blend").to_str().unwrap(),
        "--method",
        "blend",
    ]);
    assert!(ok, "{log}");
    assert!(log.contains("blend"), "{log}");
    let (ok, log) = dynview(&[
        "render",
        "--scene",
        event.join("scene").to_str().unwrap(),
        "--path",
        event.join("camera_path_static.json").to_str().unwrap(),
        "--out",
        tmp.path().join("p").to_str().unwrap(),
        "--params",
        params.to_str().unwrap(),
        "--no-temporal",
    ]);
    assert!(ok, "{log}");
    assert!(log.contains("no-temporal"), "{log}");
}

#[test]
fn render_rejects_bad_paths_and_parameters_clearly() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    let (ok, log) = dynview(&[
        "synth",
        "--out",
        event.to_str().unwrap(),
        "--cameras",
        "2",
        "--frames",
        "1",
        "--width",
        "32",
        "--height",
        "18",
        "--no-video",
    ]);
    assert!(ok, "{log}");
    let scene = event.join("scene");
    let bad_path = tmp.path().join("path.json");
    fs::write(
        &bad_path,
        r#"{"render_height": 10, "render_width": 20, "camera_path": [{"camera_to_world": [1,0,0], "fov": 50, "aspect": 1}]}"#,
    )
    .unwrap();
    let (ok, log) = dynview(&[
        "render",
        "--scene",
        scene.to_str().unwrap(),
        "--path",
        bad_path.to_str().unwrap(),
        "--out",
        tmp.path().join("o").to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(log.contains("camera_path[0].camera_to_world"), "{log}");
    let params = tmp.path().join("params.json");
    fs::write(&params, r#"{"lamda_t": 0.1}"#).unwrap();
    let (ok, log) = dynview(&[
        "render",
        "--scene",
        scene.to_str().unwrap(),
        "--path",
        event.join("camera_path.json").to_str().unwrap(),
        "--out",
        tmp.path().join("o").to_str().unwrap(),
        "--params",
        params.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(log.contains("lamda_t"), "{log}");
    let (ok, log) = dynview(&[
        "render",
        "--scene",
        scene.to_str().unwrap(),
        "--path",
        event.join("camera_path.json").to_str().unwrap(),
        "--out",
        tmp.path().join("o").to_str().unwrap(),
        "--method",
        "magic",
    ]);
    assert!(!ok);
    assert!(log.contains("unknown method"), "{log}");
}

#[test]
fn render_on_the_gpu_matches_the_cpu_render() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    let (ok, log) = dynview(&[
        "synth",
        "--out",
        event.to_str().unwrap(),
        "--cameras",
        "4",
        "--frames",
        "3",
        "--width",
        "96",
        "--height",
        "54",
        "--no-video",
    ]);
    assert!(ok, "{log}");
    let scene = event.join("scene");
    let path = event.join("camera_path.json");
    let render = |out: &str, extra: &[&str]| {
        let mut args = vec!["render", "--scene", scene.to_str().unwrap(), "--path", path.to_str().unwrap(), "--out", out];
        args.extend_from_slice(extra);
        dynview(&args)
    };
    let (cpu_dir, gpu_dir) = (tmp.path().join("cpu"), tmp.path().join("gpu"));
    let (ok, log) = render(cpu_dir.to_str().unwrap(), &[]);
    assert!(ok, "{log}");
    let (ok, log) = render(gpu_dir.to_str().unwrap(), &["--gpu"]);
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
    let (ok, log) = render(tmp.path().join("x").to_str().unwrap(), &["--gpu", "--method", "blend"]);
    assert!(!ok && log.contains("runs on the CPU"), "{log}");
}
