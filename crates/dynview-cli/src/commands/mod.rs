//! One module per subcommand: argument parsing and wiring only, no math.

pub mod colmap;
pub mod frames;
pub mod info;
#[cfg(feature = "prep")]
pub mod merge;
pub mod package;
#[cfg(feature = "prep")]
pub mod prep;
pub mod render;
pub mod synth;
