//! Clocks from the cameras' sound: every camera that recorded the same event heard the same
//! claps, whistles and ball hits, so the lag between two tracks' sounds gives their offset, and
//! the way that lag creeps along the recording gives their drift.
//!
//! [`align_audio`] works in four steps:
//! 1. **Coarse lag** per pair of tracks: an onset-strength envelope per track (log energy in
//!    10 ms hops, half-wave-rectified difference) cross-correlated by FFT over lags within
//!    ±[`AudioOptions::max_offset_s`]; of its best few lags, the one at which the most short
//!    windows of the samples peak clearly (alike sounds, a ball's knocks, can match the wrong
//!    one in the envelopes), with its peak-to-sidelobe ratio.
//! 2. **Drift guess**: the same envelopes correlated in segments along the overlap give a line
//!    lag(t) good to a few milliseconds.
//! 3. **GCC-PHAT refinement** in windows along the overlap (short ones first, then windows of
//!    [`AudioOptions::drift_window_s`]), on the raw samples with the second track resampled to
//!    follow the lag line, so drift does not blur the peak; each window of the second pass is
//!    measured by its sounds, the median lag of 64 ms windows inside it (a long window holds
//!    sounds from several places, heard with different lags, and its peak can fall between
//!    them, milliseconds off), and the windows' lags are fitted by a robust line: the pair's
//!    offset and rate ratio.
//! 4. **Joint solve**: weighted least squares over all reliable pairs (log-rates first, then
//!    starts) with the first track fixed, dropping the pair that disagrees most while it is over
//!    [`AudioOptions::outlier_threshold_s`] and the others still connect every camera.
//!
//! The timeline is the first track's clock: track 0 gets [`Clock::SYNCHRONIZED`], and track `c`
//! gets the clock that maps track-0 time to track-`c` time (a sound heard at `s0` in track 0 is
//! heard at `start_s + rate * s0` in track `c`).

pub use input::AudioTrack;
pub use pair::PairMeasurement;

mod envelope;
mod fft;
mod gcc;
mod input;
mod line;
mod options;
mod pair;
mod solve;

#[cfg(test)]
mod test_signal;
#[cfg(test)]
mod tests;

use serde::{Deserialize, Serialize};

use crate::clock::Clock;
use crate::error::{SyncError, SyncResult};

pub use options::{AudioOptions, MAX_SAMPLE_RATE_HZ, MAX_TRACK_S, MAX_TRACKS, MIN_SAMPLE_RATE_HZ, MIN_TRACK_S};

/// One camera's clock found from its sound.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AudioClock {
    /// The camera's name.
    pub camera: String,
    /// Maps the first track's time to this track's time.
    pub clock: Clock,
    /// How far to trust the clock, 0 to 1: the best confidence of the pairs that placed it,
    /// lowered by their disagreement with the solution; below
    /// [`AudioOptions::min_confidence`] when no reliable pair ties the camera to the first track
    /// (the caller should warn and may prefer another method for it).
    pub confidence: f64,
    /// Reliable pairs with this camera used in the joint solve.
    pub pairs_used: usize,
}

/// What one pair of tracks measured, and what the joint solve made of it (for the report).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairOffset {
    /// The measurement.
    #[serde(flatten)]
    pub measured: PairMeasurement,
    /// True when the joint solve used this pair.
    pub used: bool,
    /// How far the solved clocks disagree with this measurement (s): the offset's difference,
    /// or the rate's difference times half the measured span where that is larger.
    pub residual_s: f64,
}

/// The clocks of all tracks and what each pair measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AudioAlignment {
    /// One clock per input track, in input order; the first is [`Clock::SYNCHRONIZED`].
    pub cameras: Vec<AudioClock>,
    /// Every pair of tracks, `(0, 1), (0, 2), ..., (1, 2), ...`.
    pub pairs: Vec<PairOffset>,
}

/// Finds each track's clock against the first track's from the sound they share (see the
/// module's documentation for the method).
///
/// Errors: fewer than two tracks or more than [`MAX_TRACKS`]; an option out of range; a track
/// with no samples, silence only, a non-finite sample, a sample rate outside
/// [`MIN_SAMPLE_RATE_HZ`]..=[`MAX_SAMPLE_RATE_HZ`] or unlike the first track's, shorter than
/// [`MIN_TRACK_S`] or longer than [`MAX_TRACK_S`] ([`SyncError::Camera`] naming it);
/// [`SyncError::NoOverlap`] when no two tracks share a recognisable sound. A camera that shares
/// none with the others still gets a clock, from its best pair, with a low confidence.
///
/// ```
/// use dynview_sync::audio::{AudioOptions, AudioTrack, align_audio};
///
/// // A crowd's noise, heard by two phones; the second started 0.05 s before the first.
/// let rate_hz = 16_000u32;
/// let mut seed = 1u32;
/// let crowd: Vec<f32> = (0..6 * rate_hz)
///     .map(|_| {
///         seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
///         (seed >> 8) as f32 / (1 << 24) as f32 - 0.5
///     })
///     .collect();
/// let early = (0.05 * f64::from(rate_hz)) as usize;
/// let tracks = [
///     AudioTrack { camera: "first".into(), sample_rate_hz: rate_hz, samples: crowd[early..].to_vec() },
///     AudioTrack { camera: "second".into(), sample_rate_hz: rate_hz, samples: crowd.clone() },
/// ];
/// let alignment = align_audio(&tracks, &AudioOptions::default())?;
/// // A sound at time s of the first track is at 0.05 + s in the second.
/// assert!((alignment.cameras[1].clock.start_s - 0.05).abs() < 1e-4);
/// assert_eq!(alignment.cameras[1].clock.rate, 1.0);
/// # Ok::<(), dynview_sync::SyncError>(())
/// ```
pub fn align_audio(tracks: &[AudioTrack], options: &AudioOptions) -> SyncResult<AudioAlignment> {
    options.check()?;
    input::check_tracks(tracks)?;
    let sample_rate_hz = f64::from(tracks[0].sample_rate_hz);
    let envelopes: Vec<_> = tracks.iter().map(|t| envelope::Envelope::from_samples(&t.samples, sample_rate_hz)).collect();
    let mut fft = fft::FftWork::new();
    let mut measured = Vec::new();
    for a in 0..tracks.len() {
        for b in a + 1..tracks.len() {
            let pair = pair::PairInput {
                a,
                b,
                samples_a: &tracks[a].samples,
                samples_b: &tracks[b].samples,
                envelope_a: &envelopes[a],
                envelope_b: &envelopes[b],
                sample_rate_hz,
            };
            measured.push(pair::measure_pair(&mut fft, &pair, options));
        }
    }
    if !measured.iter().any(|p| p.confidence >= options.min_confidence && p.confidence > 0.0) {
        let best = measured.iter().max_by(|p, q| p.confidence.total_cmp(&q.confidence));
        let best = best.map_or(String::new(), |p| {
            format!(" (best pair: {} and {}, confidence {:.2})", tracks[p.a].camera, tracks[p.b].camera, p.confidence)
        });
        return Err(SyncError::NoOverlap(format!(
            "no two sound tracks share a recognisable sound within ±{} s with confidence {} or more{best}",
            options.max_offset_s, options.min_confidence
        )));
    }
    let names: Vec<String> = tracks.iter().map(|t| t.camera.clone()).collect();
    let solution = solve::solve_clocks(&names, &measured, options)?;
    let cameras = tracks
        .iter()
        .enumerate()
        .map(|(c, track)| AudioClock {
            camera: track.camera.clone(),
            clock: solution.clocks[c],
            confidence: solution.confidence[c],
            pairs_used: solution.pairs_used[c],
        })
        .collect();
    let pairs = measured
        .iter()
        .enumerate()
        .map(|(p, m)| PairOffset { measured: m.clone(), used: solution.used[p], residual_s: solution.residual_s[p] })
        .collect();
    Ok(AudioAlignment { cameras, pairs })
}
