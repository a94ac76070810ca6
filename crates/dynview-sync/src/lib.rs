//! Time alignment of unsynchronized cameras (phones started by hand, at mixed frame rates, with
//! drifting clocks).
//!
//! Every camera `c` has a clock model ([`clock::Clock`]): the time `s` in its own video
//! (seconds from its first frame) at which timeline time `tau` was filmed is
//! `s = start_s + rate * tau`. [`timeline`] builds the package's time steps from each camera's
//! per-frame timestamps and clock; [`audio`] estimates the clocks from the cameras' sound.

pub mod audio;
pub mod clock;
pub mod error;
pub mod timeline;

pub use clock::Clock;
pub use error::SyncError;
