//! End-to-end tests of [`crate::generate`]: the default event's outputs and an unsynchronized
//! event's videos (frame times, rotation, audio) against its ground truth. The video checks
//! need `ffmpeg` and `ffprobe` and are skipped without them.

use std::path::Path;
use std::process::Command;

use crate::unsync::{FrameTimes, UnsyncConfig};
use crate::{SynthConfig, SynthError, SynthReport, ffmpeg_available, generate};

fn tiny() -> SynthConfig {
    SynthConfig { cameras: 4, frames: 30, width: 64, height: 48, point_fraction: 0.02, ..SynthConfig::default() }
}

fn pngs(dir: &Path) -> usize {
    std::fs::read_dir(dir).unwrap().filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "png")).count()
}

fn tools_available() -> bool {
    ffmpeg_available() && Command::new("ffprobe").arg("-version").output().is_ok_and(|o| o.status.success())
}

fn probe(video: &Path, args: &[&str]) -> String {
    let output = Command::new("ffprobe").args(["-v", "error"]).args(args).arg(video).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    String::from_utf8(output.stdout).unwrap()
}

/// Presentation times of the video's frames (s).
fn frame_times_s(video: &Path) -> Vec<f64> {
    probe(video, &["-select_streams", "v:0", "-show_entries", "frame=pts_time", "-of", "csv=p=0"])
        .lines()
        .filter_map(|l| l.split(',').next().and_then(|v| v.trim().parse().ok()))
        .collect()
}

/// The video's audio track decoded to mono samples.
fn audio_samples(video: &Path) -> Vec<f32> {
    let output = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(video)
        .args(["-map", "0:a:0", "-f", "f32le", "-ac", "1", "-"])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    output.stdout.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
}

#[test]
fn the_default_event_has_no_unsync_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("event");
    let config = SynthConfig { frames: 3, videos: false, ..tiny() };
    let report = generate(&config, &out, &|_, _, _| {}).unwrap();
    assert!(report.time_alignment.is_none());
    let text = std::fs::read_to_string(out.join("synth.json")).unwrap();
    assert!(!text.contains("unsync") && !text.contains("time_alignment"), "{text}");
    assert!(!out.join("unsync").exists() && !out.join(".steps").exists());
    for c in 0..config.cameras {
        assert_eq!(pngs(&out.join("input").join(SynthConfig::camera_name(c))), 3);
    }
    let images = std::fs::read_to_string(out.join("colmap/images.txt")).unwrap();
    assert!(images.contains("cam03/00002.png") && !images.contains("cam03/00003.png"));
}

#[test]
fn held_out_cameras_get_object_ids_and_the_list_of_what_moves() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("event");
    let config = SynthConfig { frames: 2, videos: false, ..tiny() };
    generate(&config, &out, &|_, _, _| {}).unwrap();
    for heldout in ["heldout", "heldout_static"] {
        let folder = out.join(heldout).join(crate::OBJECT_DIR);
        assert_eq!(pngs(&folder), 2, "{heldout}");
        let list: Vec<crate::ObjectEntry> = serde_json::from_slice(&std::fs::read(folder.join(crate::OBJECTS_FILE)).unwrap()).unwrap();
        let moving: Vec<&str> = list.iter().filter(|o| o.moving).map(|o| o.label.as_str()).collect();
        assert_eq!(moving, ["bouncing sphere", "spinning box"]);
        assert!(list.iter().enumerate().all(|(i, o)| usize::from(o.id) == i + 1));
        // Every id in the images names an object of the list (or nothing).
        let ids = image::open(folder.join("00001.png")).unwrap().to_luma8();
        assert!(ids.pixels().all(|p| usize::from(p.0[0]) <= list.len()));
        assert!(ids.pixels().any(|p| p.0[0] > 0));
    }
}

#[test]
fn plain_movers_join_the_moving_things_untextured() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("event");
    let config = SynthConfig { frames: 2, videos: false, width: 160, height: 90, plain_movers: true, ..tiny() };
    generate(&config, &out, &|_, _, _| {}).unwrap();
    let folder = out.join("heldout").join(crate::OBJECT_DIR);
    let list: Vec<crate::ObjectEntry> = serde_json::from_slice(&std::fs::read(folder.join(crate::OBJECTS_FILE)).unwrap()).unwrap();
    let moving: Vec<&str> = list.iter().filter(|o| o.moving).map(|o| o.label.as_str()).collect();
    assert_eq!(moving, ["bouncing sphere", "spinning box", "plain bouncing sphere", "plain spinning box"]);
    // The held-out camera sees both, each in one colour inside its outline (shading aside: one
    // hue; outline pixels mix with what is behind).
    let ids = image::open(folder.join("00000.png")).unwrap().to_luma8();
    let color = image::open(out.join("heldout/color/00000.png")).unwrap().to_rgb8();
    let (w, h) = ids.dimensions();
    let inside = |x: u32, y: u32, id: u8| {
        x > 0
            && y > 0
            && x + 1 < w
            && y + 1 < h
            && [(x, y), (x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)].iter().all(|&(u, v)| ids.get_pixel(u, v).0[0] == id)
    };
    for entry in list.iter().filter(|o| o.label.starts_with("plain")) {
        let pixels: Vec<[u8; 3]> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| inside(x, y, entry.id))
            .map(|(x, y)| color.get_pixel(x, y).0)
            .collect();
        assert!(pixels.len() > 10, "{} seen on {} pixels", entry.label, pixels.len());
        let hue = |c: &[u8; 3]| f64::from(c[0]) / (f64::from(c[0]) + f64::from(c[1]) + f64::from(c[2]) + 1.0);
        let (lo, hi) = pixels.iter().map(hue).fold((1.0f64, 0.0f64), |(lo, hi), h| (lo.min(h), hi.max(h)));
        assert!(hi - lo < 0.05, "{}: red share {lo:.3}..{hi:.3}", entry.label);
    }
}

#[test]
fn unsync_options_are_checked_with_the_event() {
    let config = SynthConfig { unsync: Some(UnsyncConfig::phones(3, 30.0, 1)), ..tiny() };
    match config.validate() {
        Err(SynthError::Config { field, problem }) => assert!(field == "unsync.start_offsets_s" && problem.contains("(4)"), "{problem}"),
        other => panic!("{other:?}"),
    }
    let config = SynthConfig { unsync: Some(UnsyncConfig { drift_camera: Some(4), ..UnsyncConfig::phones(4, 30.0, 1) }), ..tiny() };
    assert!(matches!(config.validate(), Err(SynthError::Config { field: "unsync.drift_camera", .. })));
}

/// The first sample after `from` where the track's magnitude exceeds 30% of its peak within
/// 20 ms before to 40 ms after `expected_s`, as a time (s).
fn onset_s(track: &[f32], expected_s: f64) -> f64 {
    let at = |s: f64| ((s * 48_000.0).round().max(0.0) as usize).min(track.len());
    let window = &track[at(expected_s - 0.02)..at(expected_s + 0.04)];
    let peak = window.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let first = window.iter().position(|v| v.abs() > 0.3 * peak).unwrap();
    (at(expected_s - 0.02) + first) as f64 / 48_000.0
}

#[test]
fn an_unsync_event_records_each_camera_on_its_own_clock() {
    if !tools_available() {
        eprintln!("skipped: ffmpeg or ffprobe not installed");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("event");
    let config = SynthConfig { unsync: Some(UnsyncConfig::phones(4, 30.0, 3)), ..tiny() };
    let report = generate(&config, &out, &|_, _, _| {}).unwrap();
    assert!(report.videos_written && !out.join(".steps").exists());
    let alignment = report.time_alignment.expect("time alignment");
    assert_eq!(alignment.audio_sample_rate_hz, Some(48_000));
    let reread: SynthReport = serde_json::from_str(&std::fs::read_to_string(out.join("synth.json")).unwrap()).unwrap();
    assert_eq!(reread.time_alignment.as_ref(), Some(&alignment));

    let mut colmap_images = 0;
    for (name, timing) in &alignment.cameras {
        let truth: FrameTimes = serde_json::from_str(&std::fs::read_to_string(out.join(&timing.timestamps_file)).unwrap()).unwrap();
        let video = out.join("videos").join(format!("{name}.mp4"));
        // Every frame at its time, within a millisecond.
        let times = frame_times_s(&video);
        assert_eq!(times.len(), timing.frame_count, "{name}");
        assert_eq!(pngs(&out.join("input").join(name)), timing.frame_count, "{name}");
        for (got, want) in times.iter().zip(&truth.video_times_s) {
            assert!((got - want).abs() < 1e-3, "{name}: frame at {got} s, truth {want} s");
        }
        assert!(timing.first_event_time_s < 0.0 && timing.last_event_time_s > config.duration_s(), "{name}: {timing:?}");
        // The audio track: 48 kHz mono AAC, each bounce where the truth says.
        let audio = probe(&video, &["-select_streams", "a:0", "-show_entries", "stream=codec_name,sample_rate,channels", "-of", "csv=p=0"]);
        assert!(audio.starts_with("aac,48000,1"), "{name}: {audio}");
        let track = audio_samples(&video);
        let bounces: Vec<f64> = truth
            .sounds
            .iter()
            .filter(|s| s.event.kind == crate::sound::SoundKind::Bounce && s.arrival_video_s > 0.05)
            .map(|s| s.arrival_video_s)
            .collect();
        assert!(!bounces.is_empty(), "{name}: {:?}", truth.sounds);
        for expected_s in bounces.iter().filter(|s| **s < timing.frame_count as f64 / timing.fps - 0.1) {
            let found_s = onset_s(&track, *expected_s);
            assert!((found_s - expected_s).abs() < 1e-3, "{name}: bounce heard at {found_s} s, truth {expected_s} s");
        }
        colmap_images += timing.frame_count;
    }
    let cam = |i: usize| &alignment.cameras[&SynthConfig::camera_name(i)];
    // The 60 fps camera films twice the frames per second of the event; the variable-rate one
    // jitters.
    let per_s = |i: usize| (cam(i).frame_count - 1) as f64 / (cam(i).last_event_time_s - cam(i).first_event_time_s);
    let ratio = per_s(1) / per_s(0);
    assert!(cam(1).fps == 60.0 && (ratio - 2.0).abs() < 0.01, "{ratio}");
    let vfr = frame_times_s(&out.join("videos/cam02.mp4"));
    let intervals: Vec<f64> = vfr.windows(2).map(|w| w[1] - w[0]).collect();
    let (lo, hi) = intervals.iter().fold((1.0f64, 0.0f64), |(lo, hi), d| (lo.min(*d), hi.max(*d)));
    assert!(cam(2).vfr && hi - lo > 0.2 / 30.0, "{intervals:?}");
    assert!(cam(4 % 4).rate > 1.0);

    // The portrait camera: stored in landscape, shown upright.
    let portrait = out.join("videos/cam03.mp4");
    let stored = probe(&portrait, &["-select_streams", "v:0", "-show_entries", "stream=width,height", "-of", "csv=p=0"]);
    assert!(stored.starts_with("64,48"), "{stored}");
    assert!(probe(&portrait, &["-select_streams", "v:0", "-show_entries", "stream_side_data=rotation", "-of", "csv=p=0"]).contains("-90"));
    let shown = dir.path().join("shown.png");
    let status = Command::new("ffmpeg").args(["-v", "error", "-i"]).arg(&portrait).args(["-frames:v", "1"]).arg(&shown).status().unwrap();
    assert!(status.success());
    let shown = image::open(&shown).unwrap().to_rgb8();
    let upright = image::open(out.join("input/cam03/00000.png")).unwrap().to_rgb8();
    assert!(cam(3).portrait && cam(3).rotation_deg == 90 && (cam(3).width_px, cam(3).height_px) == (48, 64));
    assert_eq!(shown.dimensions(), (48, 64));
    assert_eq!(upright.dimensions(), (48, 64));
    let error =
        shown.as_raw().iter().zip(upright.as_raw()).map(|(a, b)| f64::from(a.abs_diff(*b))).sum::<f64>() / shown.as_raw().len() as f64;
    assert!(error < 8.0, "the portrait video does not show its frames upright: mean error {error}");

    // COLMAP lists every camera's own frames, the portrait one with its portrait lens; the
    // synchronized timeline keeps its time steps.
    let images = std::fs::read_to_string(out.join("colmap/images.txt")).unwrap();
    assert_eq!(images.lines().filter(|l| l.contains(".png")).count(), colmap_images);
    let cameras = std::fs::read_to_string(out.join("colmap/cameras.txt")).unwrap();
    assert!(cameras.lines().any(|l| l.starts_with("4 PINHOLE 48 64")), "{cameras}");
    assert_eq!(pngs(&out.join("heldout/color")), 30);
    assert_eq!(report.points_per_step.len(), 30);
}
