//! What the user gives: the cameras and their frames ([`frames`]: videos decoded by OpenCV with
//! their timestamps from [`probe`], or image folders), their sound ([`sound`]), the frames put on one timeline
//! ([`timing`]), and optionally their calibration ([`calibration`]: known intrinsics, and the
//! frames undistorted when it has a distortion).

pub mod calibration;
pub mod frames;
pub mod probe;
pub mod sound;
pub mod timing;
