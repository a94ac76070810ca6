// The fixture's size, shared by the library and the build script (`include!`d by both).

/// Input cameras of the synthetic event.
pub const CAMERAS: usize = 4;
/// Frames (time steps) of the synthetic event.
pub const FRAMES: u32 = 4;
/// Width of the input frames and of the held-out path, in pixels.
pub const WIDTH: u32 = 320;
/// Height of the input frames and of the held-out path, in pixels.
pub const HEIGHT: u32 = 180;
/// Frames of the held-out path rendered natively (frame 1 uses frame 0 in its temporal terms).
pub const NATIVE_FRAMES: u32 = 2;
