//! The top layer: the frame loop that runs the passes ([`crate::passes`]) level by level
//! ([`renderer`]), streaming with the previous frame and the uploaded inputs kept
//! ([`streaming`]), and drawing a frame into a texture ([`display`]).

pub(crate) mod display;
pub(crate) mod renderer;
pub(crate) mod streaming;
