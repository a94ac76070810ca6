//! The cameras put on one timeline: their clocks found ([`SyncMethod`]: from the pictures
//! ([`visual`]), given by the user, or taken as started together), then
//! [`dynview_sync::timeline::build`] picks, for every time step, each camera's frame filmed
//! nearest to it, and [`retime`] makes the frame a camera would have filmed at a step's moment
//! from its frames before and after.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use rayon::prelude::*;

use serde::{Deserialize, Serialize};

use dynview_sync::Clock;
use dynview_sync::audio::{AudioOptions, AudioTrack, align_audio};
use dynview_sync::timeline::{self, CameraTimes, Moment};

use dynview_core::StageProgress;
use dynview_interchange::poses::CameraPoses;

use crate::error::{SfmError, SfmResult};
use crate::input::frames::{CameraFrames, CameraSource, EventFrames, RecordedCamera, WORK_FRAME_EXTENSION, encode_work_frame, read_bgr};
use crate::input::sound::{ANALYSIS_RATE_HZ, has_sound, read_sound};

use crate::work::WorkDir;
use retime::{MIN_FRACTION, RETIME_REVISION, Retime, frame_between};
use visual::{PairOffset, VisualOptions, visual_clocks};

mod moving;
pub mod retime;
pub mod solve;
pub mod visual;

/// Frames per second of image folders and of the timeline when nothing else says.
pub const DEFAULT_FPS: f64 = 30.0;
/// The revision of the visual alignment, part of its work-folder key: a work folder aligned
/// by an earlier revision aligns again. 2: the sub-frame refinement in seconds from the frames'
/// real times (variable rates), both neighbour frames in one fit. 3: each frame's own pose
/// (hand-held cameras), and a hand-held camera's moving pixels against its frames around. 4:
/// static matches dropped in pairs with a hand-held camera.
pub const VISUAL_SYNC_REVISION: u32 = 4;
/// Below this confidence a camera's clock is named in a warning.
pub const LOW_CONFIDENCE: f64 = 0.3;

/// How the cameras' clocks are found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SyncMethod {
    /// From their sound when every camera is a video with a sound track; else from the pictures
    /// when a calibration is given and the cameras' recordings differ in length; else `none`.
    #[default]
    Auto,
    /// From their sound ([`dynview_sync::audio`]; an error when a camera has none).
    Audio,
    /// From the pictures: the offsets at which what moves agrees with the epipolar geometry of
    /// the given calibration, or of the cameras placed from the static scene without one
    /// (`crate::pipeline::still_placement`; cameras on tripods).
    Visual,
    /// Every camera taken to have started with the others (frames still placed by their
    /// timestamps).
    None,
}

impl std::str::FromStr for SyncMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "audio" => Ok(Self::Audio),
            "visual" => Ok(Self::Visual),
            "none" => Ok(Self::None),
            other => Err(format!("unknown sync method {other:?} (expected auto, audio, visual or none)")),
        }
    }
}

/// What the time alignment is told.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TimeOptions {
    /// How clocks are found, when `offsets_s` is empty.
    pub sync: SyncMethod,
    /// Given by hand: per camera, the time in its video (s from its first frame) of one moment
    /// every camera filmed (a clap); every camera must be named.
    pub offsets_s: BTreeMap<String, f64>,
    /// Time steps per second (default: the slowest camera's rate, `dynview_sync::timeline::default_fps`; image folders count as
    /// [`DEFAULT_FPS`] unless this is given).
    pub fps: Option<f64>,
    /// The first time step at this time (s) of this camera's video, instead of where the last
    /// camera to start starts.
    #[serde(default)]
    pub start_at: Option<(String, f64)>,
    /// Differing frame counts without a clock are an error instead of a cut to the shortest.
    pub strict_frame_counts: bool,
    /// How offsets are found from the pictures.
    #[serde(default)]
    pub visual: VisualOptions,
    /// How a step gets the frame of a camera that did not film at its moment.
    #[serde(default)]
    pub retime: Retime,
}

/// One camera's place on the timeline, as `report.json` shows it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraTiming {
    /// The time in this camera's own video (s from its first frame) at which the package's first
    /// time step was filmed.
    pub start_s: f64,
    /// Seconds of its clock per second of the timeline (1.0 without drift).
    pub rate: f64,
    /// How sure the alignment is of this camera's clock (0 to 1; 1 when given or assumed).
    pub confidence: f64,
    /// Its frames per second (the median interval's).
    pub fps: f64,
    /// Frames it recorded.
    pub frames: usize,
    /// The largest gap (s) between a time step and the time its nearest frame of this camera was
    /// filmed.
    pub max_error_s: f64,
    /// Time steps whose frame was made from the frames filmed before and after it ([`retime`]).
    #[serde(default)]
    pub retimed: usize,
}

/// `report.json`'s `time_alignment`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeAlignment {
    /// `audio`, `visual`, `given` or `none`.
    pub method: String,
    /// Time steps per second.
    pub fps: f64,
    /// Time steps.
    pub steps: usize,
    /// The largest time error of any camera's frame (s).
    pub max_error_s: f64,
    /// Per camera name.
    pub cameras: BTreeMap<String, CameraTiming>,
    /// What each pair of cameras measured, for a user checking an unsure camera (the offset:
    /// b's video time minus a's of one moment; from the sound, at a time of a's track, with
    /// b's clock rate against a's).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pairs: Vec<String>,
    /// Per camera (in the input's order), per time step, where in the camera's recording its
    /// frame comes from. Not in the report.
    #[serde(skip)]
    pub step_sources: Vec<Vec<StepSource>>,
}

/// The event's frames, one per camera per time step, with the alignment and its warnings.
/// `calibration` (in the order of `recorded`) is needed by the visual alignment; its result is
/// kept in the work folder.
pub fn align_in_time(
    recorded: &[RecordedCamera],
    options: &TimeOptions,
    calibration: Option<&[&CameraPoses]>,
    work: &WorkDir,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<(EventFrames, TimeAlignment, Vec<String>)> {
    let image_fps = options.fps.unwrap_or(DEFAULT_FPS);
    let times: Vec<CameraTimes> = recorded
        .iter()
        .map(|r| match &r.times_s {
            Some(t) => CameraTimes { camera: r.frames.name.clone(), frame_times_s: t.clone() },
            None => CameraTimes::evenly_spaced(&r.frames.name, r.frames.files.len(), image_fps),
        })
        .collect();
    let mut warnings = Vec::new();
    let found = Found { recorded, times: &times, options, calibration, work, progress, interrupt };
    let Clocks { method, clocks, confidence, pairs } = found.clocks()?;
    if method == "none" {
        let counts: Vec<usize> = recorded.iter().map(|r| r.frames.files.len()).collect();
        if counts.iter().any(|c| *c != counts[0]) {
            let listed = recorded.iter().map(|r| format!("{}: {}", r.frames.name, r.frames.files.len())).collect::<Vec<_>>().join(", ");
            if options.strict_frame_counts {
                let shortest = counts.iter().copied().min().unwrap_or(0);
                return Err(SfmError::FrameCounts { counts: listed, shortest });
            }
            warnings.push(format!(
                "cameras have different frame counts ({listed}); they are taken as started together (give --offsets, or --poses for --sync visual, if they were not), and the event ends with the shortest"
            ));
        }
    }
    let start_s = match &options.start_at {
        None => None,
        Some((camera, seconds)) => {
            let i = recorded.iter().position(|r| &r.frames.name == camera).ok_or_else(|| SfmError::Option {
                option: "start-at",
                problem: format!("no camera is named {camera:?} (cameras: {})", names(recorded)),
            })?;
            Some(clocks[i].timeline_time_s(*seconds))
        }
    };
    let built = timeline::build_from(&times, &clocks, options.fps, start_s).map_err(sync_error)?;
    let mut cameras = Vec::new();
    let mut report = BTreeMap::new();
    let mut step_sources = Vec::new();
    for (i, r) in recorded.iter().enumerate() {
        let sources: Vec<StepSource> = built.frames[i]
            .iter()
            .zip(&built.moments[i])
            .map(|(nearest, moment)| StepSource::of(*nearest, *moment, options.retime))
            .collect();
        let retimed = sources.iter().filter(|s| matches!(s, StepSource::Between(..))).count();
        let repeats = built.frames[i].windows(2).any(|w| w[0] == w[1]);
        let files = if retimed > 0 || repeats {
            steps_files(&r.frames, &sources, &work.join("timeline").join(&r.frames.name), progress, interrupt)?
        } else {
            built.frames[i].iter().map(|j| r.frames.files[*j].clone()).collect()
        };
        cameras.push(CameraFrames { files, ..r.frames.clone() });
        step_sources.push(sources);
        let clock = built.clocks[i];
        report.insert(
            r.frames.name.clone(),
            CameraTiming {
                start_s: clock.start_s,
                rate: clock.rate,
                confidence: confidence[i],
                fps: times[i].nominal_fps().unwrap_or(built.fps),
                frames: r.frames.files.len(),
                max_error_s: built.max_error_s[i],
                retimed,
            },
        );
        if confidence[i] < LOW_CONFIDENCE {
            warnings.push(format!(
                "camera {}: its time offset is unsure (confidence {:.2}); check it, or give it with --offsets",
                r.frames.name, confidence[i]
            ));
        }
    }
    let alignment = TimeAlignment {
        method: method.into(),
        fps: built.fps,
        steps: built.steps(),
        max_error_s: built.largest_error_s(),
        cameras: report,
        pairs,
        step_sources,
    };
    Ok((EventFrames { cameras }, alignment, warnings))
}

/// Where a time step's frame of one camera comes from, in the camera's recording.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepSource {
    /// The camera's frame, as filmed.
    Frame(usize),
    /// Made a fraction of the way from the camera's frame to its next.
    Between(usize, f64),
}

impl StepSource {
    fn of(nearest: usize, moment: Moment, retime: Retime) -> Self {
        let between = (MIN_FRACTION..=1.0 - MIN_FRACTION).contains(&moment.fraction);
        if retime == Retime::Flow && between { Self::Between(moment.before, moment.fraction) } else { Self::Frame(nearest) }
    }

    /// The step's file name (`extension`: the filmed frame's, or the work frames' for a made
    /// one): the step, the frame and how far past it, so that a stage keyed by file names sees
    /// a new frame whenever the alignment or the retiming changes.
    fn file_name(&self, t: usize, extension: &str) -> String {
        match self {
            Self::Frame(j) => format!("{t:05}-{j:05}.{extension}"),
            Self::Between(j, f) => format!("{t:05}-{j:05}+{:04}r{RETIME_REVISION}.{extension}", (f * 1e4).round()),
        }
    }
}

/// A camera's files for every step in `dir`: a filmed frame shown at a step is linked there
/// (hard links where the file system allows, so that frame file names stay unique in
/// `poses.json` and the keyframe models), a frame between two filmed ones is made there; a file
/// made by the same revision after its frames is kept (its name says what it shows), files of
/// earlier alignments are removed.
fn steps_files(
    frames: &CameraFrames,
    sources: &[StepSource],
    dir: &Path,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(SfmError::io(dir))?;
    let extension = |j: usize| frames.files[j].extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
    let names: Vec<String> = sources
        .iter()
        .enumerate()
        .map(|(t, s)| match s {
            StepSource::Frame(j) => s.file_name(t, &extension(*j)),
            StepSource::Between(..) => s.file_name(t, WORK_FRAME_EXTENSION),
        })
        .collect();
    for entry in std::fs::read_dir(dir).map_err(SfmError::io(dir))?.flatten() {
        if !names.iter().any(|n| entry.file_name().to_string_lossy() == n.as_str()) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
    let total = sources.iter().filter(|s| matches!(s, StepSource::Between(..))).count() as u64;
    let done = AtomicU64::new(0);
    let label = format!("retime {}", frames.name);
    sources
        .par_iter()
        .zip(&names)
        .map(|(source, name)| {
            SfmError::check_interrupt(interrupt)?;
            let to = dir.join(name);
            match *source {
                StepSource::Frame(j) => {
                    // Linked again every run: the frames may have been decoded again.
                    let _ = std::fs::remove_file(&to);
                    if std::fs::hard_link(&frames.files[j], &to).is_err() {
                        std::fs::copy(&frames.files[j], &to).map_err(SfmError::io(&to))?;
                    }
                }
                StepSource::Between(j, fraction) => {
                    let after = frames.files.get(j + 1).unwrap_or(&frames.files[j]);
                    if is_newer(&to, &[&frames.files[j], after]) {
                        return Ok(to);
                    }
                    let made = frame_between(&read_bgr(&frames.files[j])?, &read_bgr(after)?, fraction)?;
                    dynview_core::fsutil::write_atomic(&to, encode_work_frame(&made)?.as_slice()).map_err(SfmError::io(&to))?;
                    progress(&label, done.fetch_add(1, Ordering::Relaxed) + 1, total);
                }
            }
            Ok(to)
        })
        .collect()
}

/// True when `file` exists and was written after every one of `sources`.
fn is_newer(file: &Path, sources: &[&PathBuf]) -> bool {
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    let Some(made) = modified(file) else { return false };
    sources.iter().all(|s| modified(s).is_some_and(|m| m <= made))
}

fn sync_error(error: dynview_sync::SyncError) -> SfmError {
    SfmError::TimeAlignment(error.to_string())
}

/// Clocks found for every camera (against the first camera's video time).
struct Clocks {
    method: &'static str,
    clocks: Vec<Clock>,
    confidence: Vec<f64>,
    /// What each pair measured, as `report.json` shows it.
    pairs: Vec<String>,
}

impl Clocks {
    fn certain(method: &'static str, clocks: Vec<Clock>) -> Self {
        let confidence = vec![1.0; clocks.len()];
        Self { method, clocks, confidence, pairs: Vec::new() }
    }
}

/// What the clocks are found from.
struct Found<'a> {
    recorded: &'a [RecordedCamera],
    times: &'a [CameraTimes],
    options: &'a TimeOptions,
    calibration: Option<&'a [&'a CameraPoses]>,
    work: &'a WorkDir,
    progress: StageProgress<'a>,
    interrupt: &'a AtomicBool,
}

impl Found<'_> {
    /// The clocks against the first camera's video time, their method, confidences and the
    /// pairs measured.
    fn clocks(&self) -> SfmResult<Clocks> {
        let (recorded, options) = (self.recorded, self.options);
        let n = recorded.len();
        if !options.offsets_s.is_empty() {
            return given_clocks(recorded, &options.offsets_s).map(|c| Clocks::certain("given", c));
        }
        let videos: Vec<Option<&PathBuf>> = recorded
            .iter()
            .map(|r| match &r.source {
                CameraSource::Video(p) => Some(p),
                CameraSource::Images(_) => None,
            })
            .collect();
        let method = match options.sync {
            SyncMethod::Auto if n >= 2 && videos.iter().all(|v| v.is_some_and(|p| has_sound(p))) => SyncMethod::Audio,
            SyncMethod::Auto if self.calibration.is_some() && recordings_differ(self.times) => SyncMethod::Visual,
            SyncMethod::Auto => SyncMethod::None,
            chosen => chosen,
        };
        if method != SyncMethod::None && n < 2 {
            return Err(SfmError::TimeAlignment("aligning cameras in time needs two cameras or more".into()));
        }
        match method {
            SyncMethod::Audio => self.audio(&videos),
            SyncMethod::Visual => self.visual(),
            _ => Ok(Clocks::certain("none", vec![Clock::SYNCHRONIZED; n])),
        }
    }

    fn audio(&self, videos: &[Option<&PathBuf>]) -> SfmResult<Clocks> {
        let mut tracks = Vec::new();
        let mut starts = Vec::new();
        for (r, video) in self.recorded.iter().zip(videos) {
            SfmError::check_interrupt(self.interrupt)?;
            let Some(video) = video else {
                return Err(SfmError::TimeAlignment(format!(
                    "camera {} is an image folder: it has no sound for --sync audio",
                    r.frames.name
                )));
            };
            let sound = read_sound(video)?;
            starts.push(sound.start_in_video_s);
            tracks.push(AudioTrack { camera: r.frames.name.clone(), sample_rate_hz: ANALYSIS_RATE_HZ, samples: sound.samples });
        }
        (self.progress)("sound sync", 0, 1);
        let found = align_audio(&tracks, &AudioOptions::default()).map_err(sync_error)?;
        (self.progress)("sound sync", 1, 1);
        // The sound's clocks map camera 0's track time a0 to camera c's a_c = start + rate a0;
        // a video's time is its track's time plus where the track starts in the video.
        let clocks = found
            .cameras
            .iter()
            .zip(&starts)
            .map(|(c, start_c)| Clock { start_s: c.clock.start_s + start_c - c.clock.rate * starts[0], rate: c.clock.rate })
            .collect();
        let name = |i: usize| self.recorded[i].frames.name.as_str();
        let pairs = found
            .pairs
            .iter()
            .map(|p| {
                let m = &p.measured;
                format!(
                    "{}-{}: {:.5} s at {:.1} s, rate {:.7}, confidence {:.2}{}",
                    name(m.a),
                    name(m.b),
                    m.offset_s,
                    m.time_a_s,
                    m.rate_ratio,
                    m.confidence,
                    if p.used { "" } else { ", not used" }
                )
            })
            .collect();
        Ok(Clocks { method: "audio", clocks, confidence: found.cameras.iter().map(|c| c.confidence).collect(), pairs })
    }

    fn visual(&self) -> SfmResult<Clocks> {
        let Some(calibration) = self.calibration else {
            return Err(SfmError::TimeAlignment(
                "--sync visual needs the cameras placed: give --poses (a calibration), or let prep place them from the static scene".into(),
            ));
        };
        let key = (
            "visual sync",
            VISUAL_SYNC_REVISION,
            self.recorded.iter().map(|r| &r.frames).collect::<Vec<_>>(),
            self.times,
            calibration,
            &self.options.visual,
        );
        let file = "time/visual.json";
        let (clocks, confidence, pairs): (Vec<Clock>, Vec<f64>, Vec<PairOffset>) = if self.work.is_done("time/visual", &key) {
            self.work.read_json(file)?
        } else {
            let found = visual_clocks(self.recorded, self.times, calibration, &self.options.visual, self.progress, self.interrupt)?;
            std::fs::create_dir_all(self.work.join("time")).map_err(SfmError::io(&self.work.join("time")))?;
            self.work.write_json(file, &found)?;
            self.work.mark_done("time/visual", &key)?;
            found
        };
        let name = |i: usize| self.recorded[i].frames.name.as_str();
        let pairs = pairs
            .iter()
            .map(|p| {
                format!(
                    "{}-{}: {:.4} s, {} matches, confidence {:.2}",
                    name(p.cameras[0]),
                    name(p.cameras[1]),
                    p.offset_s,
                    p.matches,
                    p.confidence
                )
            })
            .collect();
        Ok(Clocks { method: "visual", clocks, confidence, pairs })
    }
}

/// True when the cameras' recordings differ in frame count or length by more than a frame.
fn recordings_differ(times: &[CameraTimes]) -> bool {
    let lengths: Vec<(usize, f64)> =
        times.iter().map(|t| (t.frame_times_s.len(), t.frame_times_s.last().copied().unwrap_or(0.0))).collect();
    let frame_s = times.iter().filter_map(CameraTimes::nominal_fps).map(|f| 1.0 / f).fold(0.0, f64::max);
    lengths.iter().any(|(count, length)| *count != lengths[0].0 || (length - lengths[0].1).abs() > frame_s)
}

/// The cameras' names, for messages.
fn names(recorded: &[RecordedCamera]) -> String {
    recorded.iter().map(|r| r.frames.name.as_str()).collect::<Vec<_>>().join(", ")
}

/// Clocks from `--offsets`: each camera's video time of one common moment.
fn given_clocks(recorded: &[RecordedCamera], offsets_s: &BTreeMap<String, f64>) -> SfmResult<Vec<Clock>> {
    let bad = |problem: String| SfmError::Option { option: "offsets", problem };
    if let Some(unknown) = offsets_s.keys().find(|k| !recorded.iter().any(|r| &r.frames.name == *k)) {
        return Err(bad(format!("no camera is named {unknown:?} (cameras: {})", names(recorded))));
    }
    let missing: Vec<&str> = recorded.iter().map(|r| r.frames.name.as_str()).filter(|n| !offsets_s.contains_key(*n)).collect();
    if !missing.is_empty() {
        return Err(bad(format!("give every camera's offset; missing: {}", missing.join(", "))));
    }
    if let Some((name, s)) = offsets_s.iter().find(|(_, s)| !s.is_finite() || s.abs() > 1e6) {
        return Err(bad(format!("camera {name}: {s} is not a time in seconds")));
    }
    Ok(recorded.iter().map(|r| Clock { start_s: offsets_s[&r.frames.name], rate: 1.0 }).collect())
}
