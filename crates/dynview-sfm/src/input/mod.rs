//! What the user gives: the cameras and their frames ([`frames`]: videos decoded by OpenCV, or
//! image folders), and optionally their calibration ([`calibration`]: known intrinsics, and the
//! frames undistorted when it has a distortion).

pub mod calibration;
pub mod frames;
