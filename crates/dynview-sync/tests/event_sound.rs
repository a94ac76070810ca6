//! The synthetic event's own sound (knocks where the ball lands, claps, a murmur from behind the
//! scene; each heard after its travel from where it starts) on short phones' recordings.

use dynview_sync::audio::{AudioOptions, AudioTrack, align_audio};
use dynview_synth::rig::{ARC_RADIUS_M, CAMERA_HEIGHT_M, LOOK_AT, input_angle_rad};
use dynview_synth::scene::default_objects;
use dynview_synth::sound::{EventSound, SAMPLE_RATE_HZ};
use glam::DVec3;

/// Six phones on the synthetic arc, each started at its own moment and recording 1.5 to 2 s
/// (the sounds: two knocks, a clap or two and the murmur): every clock is found within a
/// millisecond of the others', as the sounds are heard (each phone's clock plus a travel time
/// that differs between these phones by up to a millisecond for any one source).
#[test]
fn the_clocks_of_short_recordings_are_found_within_a_millisecond() {
    let starts_s = [0.4205, 0.6229, 0.0185, 0.3570, 0.3469, 0.1780];
    assert_clocks_within_a_millisecond(&starts_s, 7);
}

/// Three of them: no fourth camera outvotes a pair whose onsets matched the wrong knock.
#[test]
fn three_phones_clocks_are_found_within_a_millisecond() {
    for seed in [1, 7] {
        assert_clocks_within_a_millisecond(&[0.4205, 0.6229, 0.0185], seed);
    }
}

/// Phones started at `starts_s`, the event's sound drawn from `seed`: every clock within a
/// millisecond of the others' by its true clock.
fn assert_clocks_within_a_millisecond(starts_s: &[f64], seed: u64) {
    let lengths_s = [1.6, 1.96, 1.49, 1.69, 1.83, 1.71];
    let sound = EventSound::new(&default_objects(seed), seed, -0.5, 1.5);
    let tracks: Vec<AudioTrack> = (0..starts_s.len())
        .map(|c| {
            let angle_rad = input_angle_rad(c, starts_s.len());
            let microphone_m = DVec3::new(ARC_RADIUS_M * angle_rad.sin(), CAMERA_HEIGHT_M, LOOK_AT.z + ARC_RADIUS_M * angle_rad.cos());
            let sample_count = (lengths_s[c] * f64::from(SAMPLE_RATE_HZ)) as usize;
            let samples = sound.track(microphone_m, starts_s[c], 1.0, sample_count, Some(30.0), 100 + c as u64);
            AudioTrack { camera: format!("cam{c:02}"), sample_rate_hz: SAMPLE_RATE_HZ, samples }
        })
        .collect();
    let alignment = align_audio(&tracks, &AudioOptions::default()).expect("the phones align");
    let errors_ms: Vec<f64> =
        alignment.cameras.iter().zip(starts_s).map(|(found, start_s)| (found.clock.start_s - (start_s - starts_s[0])) * 1e3).collect();
    let mut sorted = errors_ms.clone();
    sorted.sort_by(f64::total_cmp);
    let median_ms = sorted[sorted.len() / 2];
    eprintln!("start errors from the median (ms): {:?}", errors_ms.iter().map(|e| e - median_ms).collect::<Vec<_>>());
    for (c, error_ms) in errors_ms.iter().enumerate() {
        assert!((error_ms - median_ms).abs() < 1.0, "seed {seed}, cam{c:02}: {:+.2} ms from the others", error_ms - median_ms);
    }
}
