//! Upper limits that keep a hostile package from making a reader allocate gigabytes.
//! Every count read from a file is checked against these before anything is allocated.

/// Most time steps in one package (over an hour at 25 fps).
pub const MAX_TIME_STEPS: u32 = 100_000;
/// Most input cameras.
pub const MAX_CAMERAS: usize = 64;
/// Longest image side in pixels.
pub const MAX_IMAGE_SIDE_PX: u32 = 16_384;
/// Most points in the cloud of one time step (36 MB of point data).
pub const MAX_POINTS_PER_STEP: u32 = 4_000_000;
/// Largest `scene.json` accepted.
pub const MAX_MANIFEST_BYTES: u64 = 64 << 20;
/// Largest single frame file accepted.
pub const MAX_FRAME_FILE_BYTES: u64 = 256 << 20;
/// Longest camera or scene name.
pub const MAX_NAME_CHARS: usize = 64;
/// Tolerance on `R R^T = I` and `det R = 1` for poses.
pub const ROTATION_TOLERANCE: f64 = 1e-4;
/// Largest absolute coordinate (m) of a camera centre or bound; anything larger is a unit or
/// parsing mistake.
pub const MAX_ABS_COORDINATE_M: f64 = 1e7;
/// Most frames from a keyframe to the next in a camera's video: a reader decodes at most this
/// many frames to show any one.
pub const MAX_KEYFRAME_INTERVAL: u32 = 300;
