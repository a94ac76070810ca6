//! Features and their matches: SIFT with RootSIFT descriptors ([`sift`]), exhaustive matching
//! with the ratio test, cross-check and MAGSAC++ verification ([`matching`]), matching guided by
//! known poses along epipolar lines ([`guided`]), and multi-view tracks ([`tracks`]).

pub mod guided;
pub mod matching;
pub mod sift;
pub mod tracks;
