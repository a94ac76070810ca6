//! One module per subcommand: argument parsing and wiring only, no math.

pub mod colmap;
pub mod info;
pub mod package;
pub mod prep;
pub mod render;
pub mod synth;
