//! The package-format options shared by `prep`, `merge` and `repack`.

use dynview_core::scene::ffmpeg::{DEFAULT_CRF, DEFAULT_KEYFRAME_INTERVAL, VideoSettings};
use dynview_core::scene::limits::MAX_KEYFRAME_INTERVAL;

/// How the package stores its input frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FrameStorage {
    /// One VP9 video per camera with a frame index (format v2; needs ffmpeg).
    Vp9,
    /// One JPEG file per camera per time step (readable by format v1 viewers' code).
    Jpeg,
}

/// `--frames-as`, `--keyframe-every`, `--video-crf`.
#[derive(clap::Args, Debug, Clone)]
pub struct FrameArgs {
    /// How the package stores the input frames.
    #[arg(long, value_enum, default_value = "vp9")]
    frames_as: FrameStorage,
    /// Video only: a keyframe at least every N frames (showing a frame after a scrub decodes
    /// at most N).
    #[arg(long, default_value_t = DEFAULT_KEYFRAME_INTERVAL, value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_KEYFRAME_INTERVAL)))]
    keyframe_every: u32,
    /// Video only: VP9 constant-quality level, 0 (best, largest) to 63.
    #[arg(long, default_value_t = DEFAULT_CRF, value_parser = clap::value_parser!(u32).range(0..=63))]
    video_crf: u32,
    /// Write format v1 (JPEG frames, every time step's points in full) for viewers of that
    /// format; implies `--frames-as jpeg`.
    #[arg(long)]
    format_v1: bool,
}

impl FrameArgs {
    /// The video settings, or `None` for JPEG frames.
    pub fn video(&self) -> Option<VideoSettings> {
        (self.frames_as == FrameStorage::Vp9 && !self.format_v1)
            .then_some(VideoSettings { crf: self.video_crf, keyframe_interval: self.keyframe_every })
    }

    /// Whether format v1 is asked for.
    pub fn format_v1(&self) -> bool {
        self.format_v1
    }
}
