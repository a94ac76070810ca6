//! Frames for moments a camera did not film: a camera whose clock is not the timeline's films
//! each time step up to half a frame early or late, and what moves is then seen where it was
//! at another moment than in the other cameras (a ball 5 cm off at 3 m/s and 16 ms), which
//! triangulation and blending turn into ghosts. [`frame_between`] makes the frame the camera
//! would have filmed at the step's moment from its two frames around it, each moved along the
//! optical flow between them (OpenCV's DIS flow, both ways), the two blended by how near the
//! moment is to each and by whether the flow there holds both ways (where something comes into
//! view, the frame that sees it).

use opencv::core::{BORDER_REPLICATE, Mat, Scalar, Vec2f, Vec3b};
use opencv::imgproc;
use opencv::prelude::*;
use opencv::video::DISOpticalFlow;
use serde::{Deserialize, Serialize};

use crate::error::{SfmError, SfmResult};

/// The revision of [`frame_between`], part of a made frame's file name: frames made by an
/// earlier revision are made again.
pub const RETIME_REVISION: u32 = 1;

/// Nearer than this fraction of a frame interval to a filmed frame, the step takes that frame
/// as it is (a synchronized camera's frames are never remade).
pub const MIN_FRACTION: f64 = 0.02;

/// How far (px) the flow may fail to return to where it started before a frame's colour there
/// counts less (a Gaussian weight of this width).
const ROUND_TRIP_PX: f32 = 1.5;

/// How a time step gets a camera's frame when the camera did not film at the step's moment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Retime {
    /// Made from the frames before and after the moment, moved along the optical flow.
    #[default]
    Flow,
    /// The frame filmed nearest to the moment, as it is.
    Nearest,
}

impl std::str::FromStr for Retime {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "flow" => Ok(Self::Flow),
            "nearest" => Ok(Self::Nearest),
            other => Err(format!("unknown retime method {other:?} (expected flow or nearest)")),
        }
    }
}

/// The frame filmed `fraction` (0 to 1) of the way from `before` to `after` (8-bit BGR of one
/// size), from the optical flow between them.
pub fn frame_between(before: &Mat, after: &Mat, fraction: f64) -> SfmResult<Mat> {
    let size = before.size().map_err(SfmError::cv("frame size"))?;
    if after.size().map_err(SfmError::cv("frame size"))? != size || before.typ() != after.typ() || before.typ() != opencv::core::CV_8UC3 {
        return Err(SfmError::Reconstruction(format!("frames to retime differ in size or type ({:?} and {:?})", size, after.size().ok())));
    }
    let t = fraction.clamp(0.0, 1.0) as f32;
    let (width, height) = (size.width as usize, size.height as usize);
    let forward = flow(before, after)?;
    let backward = flow(after, before)?;
    let f01 = forward.data_typed::<Vec2f>().map_err(SfmError::cv("flow"))?;
    let f10 = backward.data_typed::<Vec2f>().map_err(SfmError::cv("flow"))?;
    // Where each pixel of the frame to make comes from in each frame, assuming motion along a
    // straight line at constant speed (the flows at the same pixel stand in for the flow
    // through it).
    let mut from_before = Vec::with_capacity(width * height);
    let mut from_after = Vec::with_capacity(width * height);
    for (i, (a, b)) in f01.iter().zip(f10).enumerate() {
        let (x, y) = ((i % width) as f32, (i / width) as f32);
        let to_before = [-(1.0 - t) * t * a[0] + t * t * b[0], -(1.0 - t) * t * a[1] + t * t * b[1]];
        let to_after = [(1.0 - t) * (1.0 - t) * a[0] - t * (1.0 - t) * b[0], (1.0 - t) * (1.0 - t) * a[1] - t * (1.0 - t) * b[1]];
        from_before.push(Vec2f::from([x + to_before[0], y + to_before[1]]));
        from_after.push(Vec2f::from([x + to_after[0], y + to_after[1]]));
    }
    let from_before = map_mat(&from_before, size.height)?;
    let from_after = map_mat(&from_after, size.height)?;
    let trip_before = warp(&round_trip_px(f01, &backward, width, height)?, &from_before)?;
    let trip_after = warp(&round_trip_px(f10, &forward, width, height)?, &from_after)?;
    let warped_before = warp(before, &from_before)?;
    let warped_after = warp(after, &from_after)?;
    let (pb, pa) = (
        warped_before.data_typed::<Vec3b>().map_err(SfmError::cv("warped frame"))?,
        warped_after.data_typed::<Vec3b>().map_err(SfmError::cv("warped frame"))?,
    );
    let (eb, ea) = (
        trip_before.data_typed::<f32>().map_err(SfmError::cv("round trip"))?,
        trip_after.data_typed::<f32>().map_err(SfmError::cv("round trip"))?,
    );
    let trust = |error_px: f32| (-(error_px / ROUND_TRIP_PX).powi(2)).exp() + 1e-3;
    let mut out = Vec::with_capacity(width * height);
    for i in 0..width * height {
        let wb = (1.0 - t) * trust(eb[i]);
        let wa = t * trust(ea[i]);
        let mix = |c: usize| ((wb * pb[i][c] as f32 + wa * pa[i][c] as f32) / (wb + wa)).round().clamp(0.0, 255.0) as u8;
        out.push(Vec3b::from([mix(0), mix(1), mix(2)]));
    }
    Mat::new_rows_cols_with_data(size.height, size.width, &out).and_then(|m| m.try_clone()).map_err(SfmError::cv("retimed frame"))
}

/// Dense optical flow from `from` to `to` (BGR), per pixel of `from`.
fn flow(from: &Mat, to: &Mat) -> SfmResult<Mat> {
    let gray = |image: &Mat| -> SfmResult<Mat> {
        let mut g = Mat::default();
        imgproc::cvt_color(image, &mut g, imgproc::COLOR_BGR2GRAY, 0).map_err(SfmError::cv("grayscale"))?;
        Ok(g)
    };
    let mut dis = DISOpticalFlow::create(opencv::video::DISOpticalFlow_PRESET_MEDIUM).map_err(SfmError::cv("optical flow"))?;
    let mut out = Mat::default();
    dis.calc(&gray(from)?, &gray(to)?, &mut out).map_err(SfmError::cv("optical flow"))?;
    Ok(out)
}

/// How far (px) each pixel lands from where it started when carried by `there` and then back
/// by `back` (sampled where it lands).
fn round_trip_px(there: &[Vec2f], back: &Mat, width: usize, height: usize) -> SfmResult<Mat> {
    let landing: Vec<Vec2f> =
        there.iter().enumerate().map(|(i, f)| Vec2f::from([(i % width) as f32 + f[0], (i / width) as f32 + f[1]])).collect();
    let back_there = warp(back, &map_mat(&landing, height as i32)?)?;
    let back_there = back_there.data_typed::<Vec2f>().map_err(SfmError::cv("flow"))?;
    let errors: Vec<f32> = there.iter().zip(back_there).map(|(f, b)| ((f[0] + b[0]).powi(2) + (f[1] + b[1]).powi(2)).sqrt()).collect();
    Mat::new_rows_cols_with_data(height as i32, width as i32, &errors).and_then(|m| m.try_clone()).map_err(SfmError::cv("round trip"))
}

fn map_mat(map: &[Vec2f], rows: i32) -> SfmResult<Mat> {
    let cols = map.len() as i32 / rows.max(1);
    Mat::new_rows_cols_with_data(rows, cols, map).and_then(|m| m.try_clone()).map_err(SfmError::cv("sample map"))
}

/// `image` sampled at `map` (bilinear, edges repeated).
fn warp(image: &Mat, map: &Mat) -> SfmResult<Mat> {
    let mut out = Mat::default();
    imgproc::remap(image, &mut out, map, &Mat::default(), imgproc::INTER_LINEAR, BORDER_REPLICATE, Scalar::default())
        .map_err(SfmError::cv("warping a frame"))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of a textured wall with a textured square whose left edge is at `square_x`.
    fn scene(square_x: f64) -> Mat {
        let (w, h) = (320usize, 192usize);
        let mut pixels = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let (xf, yf) = (x as f64, y as f64);
                let wall = 100.0 + 50.0 * ((xf * 0.31).sin() * (yf * 0.23).cos());
                let inside = xf >= square_x && xf < square_x + 80.0 && (60..140).contains(&y);
                let u = xf - square_x;
                let pattern = ((u * 0.17).sin() + (u * 0.41 + yf * 0.11).cos()) * ((yf * 0.29).sin() + 1.2);
                let value = if inside { 170.0 + 30.0 * pattern } else { wall };
                let v = value.round().clamp(0.0, 255.0) as u8;
                pixels.push(Vec3b::from([v, v / 2 + 40, 255 - v]));
            }
        }
        Mat::new_rows_cols_with_data(h as i32, w as i32, &pixels).unwrap().try_clone().unwrap()
    }

    fn psnr(a: &Mat, b: &Mat) -> f64 {
        let (a, b) = (a.data_bytes().unwrap(), b.data_bytes().unwrap());
        let mse = a.iter().zip(b).map(|(x, y)| (*x as f64 - *y as f64).powi(2)).sum::<f64>() / a.len() as f64;
        10.0 * (255.0f64.powi(2) / mse.max(1e-9)).log10()
    }

    #[test]
    fn the_frame_between_shows_what_moves_where_it_was_then() {
        let (before, after) = (scene(40.0), scene(52.0));
        for fraction in [0.25, 0.5, 0.75] {
            let truth = scene(40.0 + 12.0 * fraction);
            let made = frame_between(&before, &after, fraction).unwrap();
            let nearest = if fraction <= 0.5 { &before } else { &after };
            let (made_db, nearest_db) = (psnr(&made, &truth), psnr(nearest, &truth));
            assert!(made_db > nearest_db + 6.0, "fraction {fraction}: made {made_db:.1} dB, nearest frame {nearest_db:.1} dB");
        }
    }

    #[test]
    fn a_still_scene_is_kept_as_filmed() {
        let still = scene(40.0);
        let made = frame_between(&still, &still, 0.4).unwrap();
        assert!(psnr(&made, &still) > 45.0, "{:.1} dB", psnr(&made, &still));
    }

    #[test]
    fn frames_of_different_sizes_are_an_error() {
        let small = Mat::new_rows_cols_with_default(10, 10, opencv::core::CV_8UC3, Scalar::all(0.0)).unwrap();
        assert!(frame_between(&scene(0.0), &small, 0.5).is_err());
    }

    #[test]
    fn methods_are_named() {
        assert_eq!("flow".parse::<Retime>(), Ok(Retime::Flow));
        assert_eq!("nearest".parse::<Retime>(), Ok(Retime::Nearest));
        assert!("linear".parse::<Retime>().unwrap_err().contains("flow or nearest"));
    }
}
