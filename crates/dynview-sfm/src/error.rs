//! The errors of the preprocessing pipeline. Every message names the file (or camera) and what
//! is wrong with it.

use std::path::{Path, PathBuf};

/// Errors of `dynview prep`.
#[derive(Debug, thiserror::Error)]
pub enum SfmError {
    /// The input folder has a problem (no cameras, bad names, ...).
    #[error("{path}: {problem}")]
    Input {
        /// The file or folder.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// Cameras have different frame counts, no clock says how they line up, and
    /// `--strict-frame-counts` was given.
    #[error(
        "cameras have different frame counts ({counts}); taken as started together, run without --strict-frame-counts to keep the first {shortest} frames of every camera, or give --offsets"
    )]
    FrameCounts {
        /// `camera: count` for every camera.
        counts: String,
        /// The shortest count.
        shortest: usize,
    },
    /// The cameras could not be put on one timeline (no overlap in time, no usable sound, ...).
    #[error("time alignment: {0}")]
    TimeAlignment(String),
    /// A video or image could not be decoded.
    #[error("{path}: cannot decode: {problem}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        problem: String,
    },
    /// A camera's images have too few features to be registered.
    #[error(
        "camera {camera}: only {found} features in {file} (at least {needed} needed); is the video textureless, black or out of focus?"
    )]
    TooFewFeatures {
        /// The camera.
        camera: String,
        /// The frame file with the fewest features.
        file: String,
        /// Features found.
        found: usize,
        /// Features needed.
        needed: usize,
    },
    /// The reconstruction could not start or could not register every camera.
    #[error("structure from motion: {0}")]
    Reconstruction(String),
    /// An option is out of range.
    #[error("option `{option}`: {problem}")]
    Option {
        /// The option.
        option: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A work file of an earlier run is unreadable.
    #[error("{path}: {problem} (delete it to recompute the stage)")]
    WorkFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// OpenCV failed.
    #[error("OpenCV ({context}): {source}")]
    OpenCv {
        /// What we were doing.
        context: String,
        /// OpenCV's error.
        #[source]
        source: opencv::Error,
    },
    /// Bundle adjustment failed.
    #[error("bundle adjustment: {0}")]
    BundleAdjustment(#[from] dynview_ba::BaError),
    /// Reading or converting poses failed.
    #[error(transparent)]
    Poses(#[from] dynview_interchange::poses::PosesError),
    /// Reading or writing the scene package failed.
    #[error(transparent)]
    Scene(#[from] dynview_core::scene::SceneError),
    /// The run was interrupted (Ctrl-C); finished stages are kept.
    #[error("interrupted; finished stages are kept in the work folder")]
    Interrupted,
}

/// Results of this crate.
pub type SfmResult<T> = Result<T, SfmError>;

impl SfmError {
    /// A closure wrapping an I/O error with its path.
    pub fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Self + '_ {
        move |source| Self::Io { path: path.to_path_buf(), source }
    }

    /// `Err(Interrupted)` once `interrupt` is set (Ctrl-C), else `Ok`.
    pub fn check_interrupt(interrupt: &std::sync::atomic::AtomicBool) -> SfmResult<()> {
        if interrupt.load(std::sync::atomic::Ordering::Relaxed) { Err(Self::Interrupted) } else { Ok(()) }
    }

    /// A closure wrapping an OpenCV error with what was being done.
    pub fn cv(context: impl Into<String>) -> impl FnOnce(opencv::Error) -> Self {
        let context = context.into();
        move |source| Self::OpenCv { context, source }
    }
}
