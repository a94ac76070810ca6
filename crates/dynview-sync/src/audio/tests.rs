//! End-to-end tests of [`align_audio`] on synthetic event sound.

use std::sync::OnceLock;

use super::test_signal::{CameraSpec, EventSound, RATE_HZ, render};
use super::*;

/// Drift of the drifting phone: 20 ms a minute.
const DRIFT_RATE: f64 = 1.0 + 20e-3 / 60.0;

fn cameras() -> Vec<CameraSpec> {
    let camera = |name, start_s, rate, duration_s, snr_db, echo, hears_event| CameraSpec {
        name,
        start_s,
        rate,
        duration_s,
        snr_db,
        echo,
        hears_event,
    };
    vec![
        camera("pitch-side", 0.0, 1.0, 80.0, 15.0, (0.011, 0.3), true),
        camera("stand-left", 3.218_37, 1.0, 90.0, 12.0, (0.007, 0.4), true),
        camera("stand-right", -7.604_13, 1.0, 75.0, 10.0, (0.017, 0.25), true),
        camera("drifting-phone", 1.402_71, DRIFT_RATE, 85.0, 14.0, (0.004, 0.3), true),
        camera("goal", -12.345_67, 1.0, 70.0, 20.0, (0.023, 0.2), true),
        camera("pocket", 0.0, 1.0, 80.0, 15.0, (0.0, 0.0), false),
    ]
}

/// Six tracks of one event (the last hears none of it) and their alignment, made once.
fn scene() -> &'static (Vec<AudioTrack>, AudioAlignment) {
    static SCENE: OnceLock<(Vec<AudioTrack>, AudioAlignment)> = OnceLock::new();
    SCENE.get_or_init(|| {
        let sound = EventSound::random(7, -20.0, 100.0, 4.0);
        let tracks: Vec<AudioTrack> = cameras().iter().enumerate().map(|(c, spec)| render(&sound, spec, 100 + c as u64)).collect();
        let alignment = align_audio(&tracks, &AudioOptions::default()).expect("the scene aligns");
        for pair in &alignment.pairs {
            eprintln!("{pair:?}");
        }
        (tracks, alignment)
    })
}

#[test]
fn every_start_is_found_within_a_tenth_of_a_millisecond() {
    let (_, alignment) = scene();
    assert_eq!(alignment.cameras[0].clock, Clock::SYNCHRONIZED);
    for (spec, found) in cameras().iter().zip(&alignment.cameras).filter(|(spec, _)| spec.hears_event) {
        let error_s = found.clock.start_s - spec.start_s;
        eprintln!("{}: start error {:.1} µs, confidence {:.2}, pairs {}", spec.name, error_s * 1e6, found.confidence, found.pairs_used);
        assert!(error_s.abs() < 1e-4, "{}: start {} s, truth {} s", spec.name, found.clock.start_s, spec.start_s);
        assert!(found.confidence > 0.8, "{}: confidence {}", spec.name, found.confidence);
        assert!(found.pairs_used >= 3, "{}: {} pairs used", spec.name, found.pairs_used);
    }
}

#[test]
fn the_drifting_phones_rate_is_found() {
    let (_, alignment) = scene();
    let spec = &cameras()[3];
    let found = alignment.cameras[3].clock;
    let rate_error = found.rate - spec.rate;
    // Error at the end of the recording, on the track's own time.
    let end_error_s = found.video_time_s(70.0) - (spec.start_s + spec.rate * 70.0);
    eprintln!("drift: rate error {rate_error:.2e}, error after 70 s {:.1} µs", end_error_s * 1e6);
    assert!(rate_error.abs() < 1e-6, "rate {} truth {}", found.rate, spec.rate);
    assert!(end_error_s.abs() < 1e-4, "error after 70 s: {end_error_s} s");
    for (c, camera) in alignment.cameras.iter().enumerate().take(5).filter(|(c, _)| *c != 3) {
        assert!((camera.clock.rate - 1.0).abs() < 1e-5, "camera {c} rate {}", camera.clock.rate);
    }
}

#[test]
fn a_camera_that_heard_nothing_gets_a_low_confidence() {
    let (_, alignment) = scene();
    let pocket = &alignment.cameras[5];
    eprintln!("pocket: confidence {:.3}", pocket.confidence);
    assert!(pocket.confidence < AudioOptions::default().min_confidence, "confidence {}", pocket.confidence);
    assert_eq!(pocket.pairs_used, 0);
    assert!(alignment.pairs.iter().filter(|p| p.measured.b == 5).all(|p| !p.used));
}

#[test]
fn pairs_are_reported_in_order_with_their_measurements() {
    let (_, alignment) = scene();
    let specs = cameras();
    assert_eq!(alignment.pairs.len(), 15);
    assert_eq!((alignment.pairs[0].measured.a, alignment.pairs[0].measured.b), (0, 1));
    assert_eq!((alignment.pairs[14].measured.a, alignment.pairs[14].measured.b), (4, 5));
    for pair in alignment.pairs.iter().filter(|p| p.measured.b != 5) {
        let (a, b) = (&specs[pair.measured.a], &specs[pair.measured.b]);
        // Truth: b's time of the sound heard at time t of a.
        let truth_b_s = b.start_s + b.rate * (pair.measured.time_a_s - a.start_s) / a.rate;
        let error_s = pair.measured.time_a_s + pair.measured.offset_s - truth_b_s;
        assert!(error_s.abs() < 1e-4, "pair {}-{}: offset error {error_s} s", pair.measured.a, pair.measured.b);
        assert!(
            (pair.measured.coarse_offset_s - pair.measured.offset_s).abs() < 0.06,
            "pair {}-{} coarse",
            pair.measured.a,
            pair.measured.b
        );
        assert!(pair.used && pair.measured.rate_measured && pair.residual_s < 5e-4);
    }
}

#[test]
fn short_tracks_keep_rate_one() {
    let sound = EventSound::random(11, -5.0, 20.0, 4.0);
    let mut specs = cameras();
    specs.truncate(2);
    specs[0].duration_s = 14.0;
    specs[1].duration_s = 13.0;
    specs[1].start_s = 0.812_34;
    let tracks: Vec<AudioTrack> = specs.iter().enumerate().map(|(c, spec)| render(&sound, spec, 200 + c as u64)).collect();
    let alignment = align_audio(&tracks, &AudioOptions::default()).expect("two short tracks align");
    let found = alignment.cameras[1].clock;
    assert_eq!(found.rate, 1.0);
    assert!(!alignment.pairs[0].measured.rate_measured);
    assert!((found.start_s - specs[1].start_s).abs() < 5e-4, "start {} truth {}", found.start_s, specs[1].start_s);
}

#[test]
fn tracks_that_share_no_sound_do_not_overlap() {
    let sound = EventSound::random(3, -5.0, 30.0, 4.0);
    let other = EventSound::random(4, -5.0, 30.0, 4.0);
    let specs = cameras();
    let tracks = vec![render(&sound, &specs[0], 1), render(&other, &specs[1], 2)].into_iter().map(|mut t| {
        t.samples.truncate(20 * RATE_HZ as usize);
        t
    });
    let result = align_audio(&tracks.collect::<Vec<_>>(), &AudioOptions::default());
    assert!(matches!(result, Err(SyncError::NoOverlap(_))), "{result:?}");
}

#[test]
fn unusable_tracks_are_named() {
    let track = |camera: &str, sample_rate_hz: u32, samples: Vec<f32>| AudioTrack { camera: camera.into(), sample_rate_hz, samples };
    let noise: Vec<f32> = (0..32_000).map(|i| ((i * 7919 % 1000) as f32 / 1000.0) - 0.5).collect();
    let good = track("good", RATE_HZ, noise.clone());
    let options = AudioOptions::default();
    let camera_error = |bad: AudioTrack| match align_audio(&[good.clone(), bad], &options) {
        Err(SyncError::Camera { camera, problem }) => {
            assert_eq!(camera, "bad");
            problem
        }
        other => panic!("expected a camera error, got {other:?}"),
    };
    assert!(camera_error(track("bad", RATE_HZ, Vec::new())).contains("no sound"));
    assert!(camera_error(track("bad", RATE_HZ, vec![0.25; 32_000])).contains("no sound"));
    let mut broken = noise.clone();
    broken[100] = f32::NAN;
    assert!(camera_error(track("bad", RATE_HZ, broken)).contains("sample 100"));
    assert!(camera_error(track("bad", 44_100, noise.clone())).contains("differs"));
    assert!(camera_error(track("bad", 100, noise.clone())).contains("sample rate"));
    assert!(camera_error(track("bad", RATE_HZ, noise[..8_000].to_vec())).contains("shorter"));
    // Longer than two hours: zeroed memory the check never reads.
    let too_long = vec![0.0f32; (MAX_TRACK_S as usize + 1) * MIN_SAMPLE_RATE_HZ as usize];
    let low_rate = track("good", MIN_SAMPLE_RATE_HZ, noise.clone());
    let result = align_audio(&[low_rate, track("bad", MIN_SAMPLE_RATE_HZ, too_long)], &options);
    assert!(matches!(&result, Err(SyncError::Camera { camera, problem }) if camera == "bad" && problem.contains("longer")), "{result:?}");

    assert!(matches!(align_audio(std::slice::from_ref(&good), &options), Err(SyncError::Failed(_))));
    assert!(matches!(align_audio(&[], &options), Err(SyncError::Failed(_))));
    for (option, bad) in [
        ("max_offset_s", AudioOptions { max_offset_s: 0.0, ..options.clone() }),
        ("max_offset_s", AudioOptions { max_offset_s: f64::NAN, ..options.clone() }),
        ("drift_window_s", AudioOptions { drift_window_s: 0.1, ..options.clone() }),
        ("max_windows_per_pair", AudioOptions { max_windows_per_pair: 0, ..options.clone() }),
        ("max_rate_deviation", AudioOptions { max_rate_deviation: 0.5, ..options.clone() }),
        ("min_confidence", AudioOptions { min_confidence: 2.0, ..options.clone() }),
        ("outlier_threshold_s", AudioOptions { outlier_threshold_s: -1.0, ..options.clone() }),
    ] {
        let result = align_audio(&[good.clone(), good.clone()], &bad);
        assert!(matches!(&result, Err(SyncError::Option { option: o, .. }) if *o == option), "{option}: {result:?}");
    }
}
