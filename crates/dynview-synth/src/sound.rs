//! The event's sound and each camera's microphone track.
//!
//! The sounds: a knock each time the ball touches down (where it touches), a few hand claps
//! (broadband noise bursts) at fixed points, and a soft, continuous crowd-like murmur (low-passed
//! noise, slowly swelling) from behind the scene. Every waveform is a continuous function of
//! time, so a microphone can sample it at any instant. A camera hears each source delayed by its
//! distance / [`SPEED_OF_SOUND_M_S`] and attenuated by 1 / distance, on its own clock, plus its
//! own independent noise.

use glam::DVec3;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::scene::Object;

/// Sample rate of the microphone tracks (Hz).
pub const SAMPLE_RATE_HZ: u32 = 48_000;
/// Speed of sound (m/s).
pub const SPEED_OF_SOUND_M_S: f64 = 343.0;
/// Decay time constant of a knock's ringing (s).
const KNOCK_DECAY_S: f64 = 0.025;
/// A knock's tones: frequency (Hz) and weight.
const KNOCK_TONES: [(f64, f64); 2] = [(820.0, 0.7), (2300.0, 0.3)];
/// Decay time constant of the click that opens a knock (s), and its weight.
const CLICK_DECAY_S: f64 = 0.002;
/// Weight of the click that opens a knock.
const CLICK_WEIGHT: f64 = 0.5;
/// Decay time constant of a clap (s).
const CLAP_DECAY_S: f64 = 0.012;
/// Rate of the random values a clap's noise interpolates (Hz): broadband.
const CLAP_NOISE_RATE_HZ: f64 = 24_000.0;
/// Rate of the random values the murmur interpolates (Hz): low-passed.
const MURMUR_NOISE_RATE_HZ: f64 = 1_500.0;
/// Rate of the murmur's swell (Hz).
const MURMUR_SWELL_HZ: f64 = 0.4;
/// The murmur's level at 1 m, against a knock's 1.
const MURMUR_GAIN: f64 = 0.03;
/// Where the murmur comes from (m): in front of the back wall.
const MURMUR_POSITION_M: DVec3 = DVec3::new(0.0, 1.5, -3.6);
/// Every discrete sound is silent this long after it starts (s; its decay is down by e^-10).
const SOUND_LENGTH_S: f64 = 0.25;
/// Distances below this count as this (m): no source sits on a microphone.
const MIN_DISTANCE_M: f64 = 0.5;
/// Claps per second of the span they are drawn in.
const CLAPS_PER_S: f64 = 1.0;
/// Claps keep at least this far in time from knocks and from each other (s).
const CLAP_GAP_S: f64 = 0.15;
/// Where claps may come from (m): x, y and z ranges around the action.
const CLAP_REGION_M: [[f64; 2]; 3] = [[-3.0, 3.0], [1.2, 1.6], [-2.5, 1.0]];

/// What makes a discrete sound.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SoundKind {
    /// The ball touching down: a ringing knock opened by a click.
    Bounce,
    /// A hand clap: a decaying burst of broadband noise.
    Clap,
}

/// One discrete sound of the event.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SoundEvent {
    /// What makes it.
    pub kind: SoundKind,
    /// Event time at which it starts, at its source (s).
    pub time_s: f64,
    /// Where it starts (m, world).
    pub position_m: [f64; 3],
    /// Its level at 1 m.
    pub gain: f64,
}

/// The event's sound: its discrete sounds and the murmur.
#[derive(Clone, Debug)]
pub struct EventSound {
    /// The discrete sounds, in time order.
    pub events: Vec<SoundEvent>,
    /// The murmur's level at 1 m (0: silent).
    pub murmur_gain: f64,
    seed: u64,
}

/// A random value in [-1, 1] for lattice point `index` of stream `seed` (SplitMix64).
fn lattice(seed: u64, index: i64) -> f64 {
    let mut z = seed ^ (index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Continuous noise: random values at `rate_hz`, smoothly interpolated, at time `t_s`.
fn noise(seed: u64, rate_hz: f64, t_s: f64) -> f64 {
    let x = t_s * rate_hz;
    let i = x.floor();
    let f = x - i;
    let s = f * f * (3.0 - 2.0 * f);
    let (a, b) = (lattice(seed, i as i64), lattice(seed, i as i64 + 1));
    a + (b - a) * s
}

impl SoundEvent {
    /// Its waveform `age_s` after it starts, at 1 m; `stream` seeds its noise.
    fn waveform(&self, age_s: f64, stream: u64) -> f64 {
        if !(0.0..SOUND_LENGTH_S).contains(&age_s) {
            return 0.0;
        }
        use std::f64::consts::TAU;
        let shape = match self.kind {
            SoundKind::Bounce => {
                let ring: f64 = KNOCK_TONES.iter().map(|(hz, w)| w * (TAU * hz * age_s).sin()).sum();
                ring * (-age_s / KNOCK_DECAY_S).exp()
                    + CLICK_WEIGHT * noise(stream, CLAP_NOISE_RATE_HZ, age_s) * (-age_s / CLICK_DECAY_S).exp()
            }
            SoundKind::Clap => noise(stream, CLAP_NOISE_RATE_HZ, age_s) * (-age_s / CLAP_DECAY_S).exp(),
        };
        self.gain * shape
    }

    /// Distance from the sound's source to `mic_m` (m).
    pub fn distance_m(&self, mic_m: DVec3) -> f64 {
        (DVec3::from_array(self.position_m) - mic_m).length().max(MIN_DISTANCE_M)
    }

    /// Event time at which it reaches `mic_m` (s).
    pub fn arrival_s(&self, mic_m: DVec3) -> f64 {
        self.time_s + self.distance_m(mic_m) / SPEED_OF_SOUND_M_S
    }
}

impl EventSound {
    /// The sound of `objects` over event times `[from_s, to_s]`: a knock at each touch-down
    /// of a bouncing object (at the ground under its centre), about one clap a second at points
    /// and times drawn from `seed` (away from the knocks), and the murmur.
    pub fn new(objects: &[Object], seed: u64, from_s: f64, to_s: f64) -> Self {
        let mut rng = SmallRng::seed_from_u64(seed ^ 0x50DD_50DD_0000_0001);
        let mut events: Vec<SoundEvent> = objects
            .iter()
            .flat_map(|o| o.motion.contact_times_s(from_s - SOUND_LENGTH_S, to_s).into_iter().map(move |t| (o, t)))
            .map(|(o, t)| {
                let centre = o.motion.pose(t).1;
                SoundEvent { kind: SoundKind::Bounce, time_s: t, position_m: [centre.x, 0.0, centre.z], gain: 1.0 }
            })
            .collect();
        let claps = ((to_s - from_s) * CLAPS_PER_S).round().max(2.0) as usize;
        for _ in 0..claps * 20 {
            if events.iter().filter(|e| e.kind == SoundKind::Clap).count() == claps {
                break;
            }
            let time_s = rng.random_range(from_s..=to_s.max(from_s + 1e-3));
            let position_m = CLAP_REGION_M.map(|[lo, hi]| rng.random_range(lo..hi));
            let gain = rng.random_range(0.5..0.9);
            if events.iter().all(|e| (e.time_s - time_s).abs() >= CLAP_GAP_S) {
                events.push(SoundEvent { kind: SoundKind::Clap, time_s, position_m, gain });
            }
        }
        events.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        Self { events, murmur_gain: MURMUR_GAIN, seed }
    }

    /// Noise stream of discrete sound `i`.
    fn stream(&self, i: usize) -> u64 {
        self.seed.wrapping_add(0xC1A9_0000).wrapping_mul(0x2545_F491_4F6C_DD1D) ^ i as u64
    }

    /// The murmur at its source at event time `t_s`.
    fn murmur(&self, t_s: f64) -> f64 {
        let swell = 1.0 + 0.5 * (std::f64::consts::TAU * MURMUR_SWELL_HZ * t_s).sin();
        self.murmur_gain * swell * noise(self.seed ^ 0x4D55_524D_5552, MURMUR_NOISE_RATE_HZ, t_s)
    }

    /// A microphone at `mic_m` on a camera whose clock reads `start_s + rate * t` at event
    /// time `t`: `sample_count` samples at [`SAMPLE_RATE_HZ`] from its video time 0, each the
    /// sound arriving at that instant (every source delayed by its distance / 343 m/s and
    /// attenuated by 1 / distance), plus, with `noise_db`, its own white noise that far below the
    /// track's RMS (drawn from `noise_seed`).
    pub fn track(&self, mic_m: DVec3, start_s: f64, rate: f64, sample_count: usize, noise_db: Option<f64>, noise_seed: u64) -> Vec<f32> {
        // Discrete sounds by arrival; a window of those still sounding moves along the track.
        let mut arrivals: Vec<(f64, usize, f64)> =
            self.events.iter().enumerate().map(|(i, e)| (e.arrival_s(mic_m), i, e.distance_m(mic_m))).collect();
        arrivals.sort_by(|a, b| a.0.total_cmp(&b.0));
        let murmur_distance_m = (MURMUR_POSITION_M - mic_m).length().max(MIN_DISTANCE_M);
        let murmur_delay_s = murmur_distance_m / SPEED_OF_SOUND_M_S;
        let mut first = 0;
        let clean: Vec<f64> = (0..sample_count)
            .map(|k| {
                let t_s = (k as f64 / f64::from(SAMPLE_RATE_HZ) - start_s) / rate;
                while first < arrivals.len() && arrivals[first].0 + SOUND_LENGTH_S <= t_s {
                    first += 1;
                }
                let mut value = self.murmur(t_s - murmur_delay_s) / murmur_distance_m;
                for &(arrival_s, i, distance_m) in arrivals[first..].iter().take_while(|a| a.0 <= t_s) {
                    value += self.events[i].waveform(t_s - arrival_s, self.stream(i)) / distance_m;
                }
                value
            })
            .collect();
        let rms = (clean.iter().map(|v| v * v).sum::<f64>() / clean.len().max(1) as f64).sqrt();
        let sigma = noise_db.map_or(0.0, |db| rms * 10f64.powf(-db / 20.0));
        let mut rng = SmallRng::seed_from_u64(noise_seed);
        let normal = Normal::new(0.0, sigma.max(1e-300)).ok();
        clean
            .into_iter()
            .map(|v| {
                let n = match (normal, sigma > 0.0) {
                    (Some(n), true) => n.sample(&mut rng),
                    _ => 0.0,
                };
                (v + n).clamp(-1.0, 1.0) as f32
            })
            .collect()
    }
}

/// Raw little-endian 32-bit float samples (ffmpeg's `f32le`).
pub fn f32le_bytes(samples: &[f32]) -> Vec<u8> {
    samples.iter().flat_map(|s| s.to_le_bytes()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::default_objects;

    fn one_knock(time_s: f64) -> EventSound {
        let event = SoundEvent { kind: SoundKind::Bounce, time_s, position_m: [0.0, 0.0, 0.0], gain: 1.0 };
        EventSound { events: vec![event], murmur_gain: 0.0, seed: 3 }
    }

    #[test]
    fn a_knock_arrives_after_its_travel_time_on_the_camera_clock() {
        let sound = one_knock(0.25);
        let mic = DVec3::new(6.86, 0.0, 0.0); // 20 ms away
        let (start_s, rate) = (0.1234, 1.001);
        let track = sound.track(mic, start_s, rate, 48_000, None, 0);
        let onset = track.iter().position(|v| *v != 0.0).unwrap();
        let expected_s = start_s + rate * (0.25 + 0.02);
        assert_eq!(onset, (expected_s * 48_000.0).ceil() as usize);
        // Attenuated by the distance; silent again after the sound's length.
        let peak = track.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(peak > 0.5 / 6.86 && peak < 1.6 / 6.86, "{peak}");
        let end = ((expected_s + rate * SOUND_LENGTH_S) * 48_000.0).ceil() as usize + 1;
        assert!(track[end..].iter().all(|v| *v == 0.0));
    }

    #[test]
    fn the_camera_noise_sits_its_db_below_the_sound() {
        let sound = EventSound::new(&default_objects(1), 5, 0.0, 2.0);
        let mic = DVec3::new(0.0, 1.7, 6.2);
        let clean = sound.track(mic, 0.2, 1.0, 96_000, None, 0);
        let noisy = sound.track(mic, 0.2, 1.0, 96_000, Some(20.0), 9);
        let rms = |v: &mut dyn Iterator<Item = f64>| {
            let (s, n) = v.fold((0.0, 0), |(s, n), x| (s + x * x, n + 1));
            (s / f64::from(n)).sqrt()
        };
        let signal = rms(&mut clean.iter().map(|&v| f64::from(v)));
        let noise = rms(&mut clean.iter().zip(&noisy).map(|(a, b)| f64::from(b - a)));
        assert!((noise / signal - 0.1).abs() < 0.01, "{}", noise / signal);
        assert!(signal > 1e-3);
    }

    #[test]
    fn the_event_has_knocks_at_touch_downs_and_claps_apart_from_them() {
        let sound = EventSound::new(&default_objects(1), 5, -0.5, 3.0);
        let knocks: Vec<f64> = sound.events.iter().filter(|e| e.kind == SoundKind::Bounce).map(|e| e.time_s).collect();
        assert_eq!(knocks, [-0.75, 0.0, 0.75, 1.5, 2.25, 3.0]);
        let claps: Vec<&SoundEvent> = sound.events.iter().filter(|e| e.kind == SoundKind::Clap).collect();
        assert!(claps.len() >= 3, "{}", claps.len());
        for clap in claps {
            assert!(sound.events.iter().all(|e| e == clap || (e.time_s - clap.time_s).abs() >= CLAP_GAP_S));
        }
        assert!(sound.events.windows(2).all(|w| w[0].time_s <= w[1].time_s));
    }
}
