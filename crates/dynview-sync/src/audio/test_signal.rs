//! Synthetic event sound for the tests: clicks (hits, steps, claps), noise bursts (shouts,
//! scrapes) and chirps (whistles) at random times, defined at every real time so a camera's
//! track can be sampled with any start, drift and fractional delay without interpolation.

use std::f64::consts::PI;

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::AudioTrack;

/// Sample rate of the test tracks (Hz).
pub(super) const RATE_HZ: u32 = 16_000;
/// Sinusoids in a noise burst.
const BURST_PARTIALS: usize = 6;

#[derive(Clone, Copy, Debug)]
enum Kind {
    Click { frequency_hz: f64, decay_s: f64 },
    Burst { partials: [(f64, f64); BURST_PARTIALS] },
    Chirp { from_hz: f64, to_hz: f64 },
}

#[derive(Clone, Copy, Debug)]
struct Event {
    start_s: f64,
    duration_s: f64,
    amplitude: f64,
    kind: Kind,
}

impl Event {
    fn value(&self, time_s: f64) -> f64 {
        let u = time_s - self.start_s;
        if !(0.0..self.duration_s).contains(&u) {
            return 0.0;
        }
        let hann = 0.5 - 0.5 * (2.0 * PI * u / self.duration_s).cos();
        self.amplitude
            * match self.kind {
                Kind::Click { frequency_hz, decay_s } => (-u / decay_s).exp() * (2.0 * PI * frequency_hz * u).sin(),
                Kind::Burst { partials } => {
                    hann * partials.iter().map(|(f, phase)| (2.0 * PI * f * u + phase).sin()).sum::<f64>() / (BURST_PARTIALS as f64).sqrt()
                }
                Kind::Chirp { from_hz, to_hz } => {
                    hann * (2.0 * PI * (from_hz * u + (to_hz - from_hz) * u * u / (2.0 * self.duration_s))).sin()
                }
            }
    }
}

/// The sound of the event, at times of the first camera's clock.
pub(super) struct EventSound {
    events: Vec<Event>,
    longest_s: f64,
}

impl EventSound {
    /// Random events over `[from_s, to_s)` at about `per_second` a second.
    pub(super) fn random(seed: u64, from_s: f64, to_s: f64, per_second: f64) -> Self {
        let mut rng = SmallRng::seed_from_u64(seed);
        let count = ((to_s - from_s) * per_second) as usize;
        let mut events: Vec<Event> = (0..count)
            .map(|_| {
                let start_s = rng.random_range(from_s..to_s);
                let amplitude = 10f64.powf(rng.random_range(-1.3..0.0));
                let pick: f64 = rng.random_range(0.0..1.0);
                if pick < 0.5 {
                    let decay_s = rng.random_range(0.002..0.015);
                    let kind = Kind::Click { frequency_hz: rng.random_range(300.0..5000.0), decay_s };
                    Event { start_s, duration_s: 6.0 * decay_s, amplitude, kind }
                } else if pick < 0.85 {
                    let partials = std::array::from_fn(|_| (rng.random_range(200.0..6000.0), rng.random_range(0.0..2.0 * PI)));
                    Event { start_s, duration_s: rng.random_range(0.03..0.3), amplitude, kind: Kind::Burst { partials } }
                } else {
                    let kind = Kind::Chirp { from_hz: rng.random_range(300.0..3000.0), to_hz: rng.random_range(300.0..3000.0) };
                    Event { start_s, duration_s: rng.random_range(0.15..0.6), amplitude, kind }
                }
            })
            .collect();
        events.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
        let longest_s = events.iter().map(|e| e.duration_s).fold(0.0, f64::max);
        Self { events, longest_s }
    }

    /// The sound at `time_s`; `cursor` (start at 0) speeds up calls at increasing times.
    fn value(&self, time_s: f64, cursor: &mut usize) -> f64 {
        while *cursor < self.events.len() && self.events[*cursor].start_s + self.longest_s < time_s {
            *cursor += 1;
        }
        self.events[*cursor..].iter().take_while(|e| e.start_s <= time_s).map(|e| e.value(time_s)).sum()
    }
}

/// How one camera heard the event.
#[derive(Clone, Debug)]
pub(super) struct CameraSpec {
    /// The camera's name.
    pub name: &'static str,
    /// The true clock's start (s): the event's time 0 is at this time of the track.
    pub start_s: f64,
    /// The true clock's rate.
    pub rate: f64,
    /// The track's length (s).
    pub duration_s: f64,
    /// Signal-to-noise ratio of the track (dB).
    pub snr_db: f64,
    /// An echo `(delay s, gain)` of the event's sound.
    pub echo: (f64, f64),
    /// False for a camera that heard none of the event (noise only).
    pub hears_event: bool,
}

/// The camera's track: the event's sound (and echo) on the camera's clock, scaled, plus its own
/// white noise and 50 Hz hum.
pub(super) fn render(sound: &EventSound, camera: &CameraSpec, seed: u64) -> AudioTrack {
    let rate_hz = f64::from(RATE_HZ);
    let length = (camera.duration_s * rate_hz) as usize;
    let (mut direct, mut echoed) = (0usize, 0usize);
    let mut samples: Vec<f64> = (0..length)
        .map(|n| {
            if !camera.hears_event {
                return 0.0;
            }
            let event_s = (n as f64 / rate_hz - camera.start_s) / camera.rate;
            sound.value(event_s, &mut direct) + camera.echo.1 * sound.value(event_s - camera.echo.0, &mut echoed)
        })
        .collect();
    let power = if camera.hears_event { samples.iter().map(|x| x * x).sum::<f64>() / length.max(1) as f64 } else { 0.01 };
    let noise_deviation = (power / 10f64.powf(camera.snr_db / 10.0)).sqrt();
    let mut rng = SmallRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, noise_deviation).expect("a finite noise level");
    let hum_phase = rng.random_range(0.0..2.0 * PI);
    for (n, x) in samples.iter_mut().enumerate() {
        *x += noise.sample(&mut rng) + noise_deviation * (2.0 * PI * 50.0 * n as f64 / rate_hz + hum_phase).sin();
    }
    AudioTrack { camera: camera.name.into(), sample_rate_hz: RATE_HZ, samples: samples.iter().map(|&x| (0.5 * x) as f32).collect() }
}
