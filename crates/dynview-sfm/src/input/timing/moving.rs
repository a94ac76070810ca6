//! What moves in a camera's frames, for the visual alignment: the pixels that differ from the
//! camera's still image of the scene.
//!
//! On a tripod the still image is one for the whole recording: the per-pixel median of frames
//! spread over it ([`median_image`]). A hand-held camera's median is a blur of the moving
//! background, so each of its frames gets its own ([`compensated_still`]): frames a few steps
//! before and after it, each warped onto it by the homography that corners tracked between the
//! two give (RANSAC leaves what moves out), and their per-pixel median. What moves has moved on
//! in most of them; the static scene lies where it lies in the frame, up to the parallax a
//! homography cannot follow.

use opencv::core::{self, Mat, Point, Point2f, Scalar, Size, TermCriteria, Vector};
use opencv::prelude::*;
use opencv::{calib3d, imgproc, video};

use crate::error::{SfmError, SfmResult};

/// Frames (before and after, in frames) whose warped median makes a hand-held frame's still
/// image: what moves clears a pixel within a few tenths of a second, the camera's own motion
/// over that span is what a homography follows.
pub const COMPENSATED_STEPS: [i64; 8] = [-12, -9, -6, -3, 3, 6, 9, 12];

/// A pixel gets a compensated still value only where this many warped frames cover it; else
/// the frame's own value (it does not move).
const MIN_COVERING_FRAMES: usize = 3;

/// Corners tracked from a frame into each of its neighbours.
const TRACKED_CORNERS: i32 = 400;

/// Fewest tracked corners a neighbour needs for its homography.
const MIN_TRACKED: usize = 16;

/// RANSAC threshold of the neighbours' homographies (px at the working size).
const HOMOGRAPHY_PX: f64 = 2.0;

/// The per-pixel median of up to `count` frames spread over `gray` (8-bit, one channel, one
/// size).
pub fn median_image(gray: &[Mat], count: usize) -> SfmResult<Vec<u8>> {
    let step = (gray.len() / count.max(1)).max(1);
    let picked: Vec<&[u8]> =
        gray.iter().step_by(step).map(|g| g.data_bytes().map_err(SfmError::cv("frame bytes"))).collect::<SfmResult<_>>()?;
    Ok(pixel_medians(&picked, None, None))
}

/// The still image of frame `index` of a camera that moves: its neighbours at
/// [`COMPENSATED_STEPS`] warped onto it, the per-pixel median of those covering a pixel.
pub fn compensated_still(gray: &[Mat], index: usize) -> SfmResult<Vec<u8>> {
    let frame = &gray[index];
    let size = frame.size().map_err(SfmError::cv("frame size"))?;
    let mut corners: Vector<Point2f> = Vector::new();
    imgproc::good_features_to_track_def(frame, &mut corners, TRACKED_CORNERS, 0.01, 8.0).map_err(SfmError::cv("corners"))?;
    let own = frame.data_bytes().map_err(SfmError::cv("frame bytes"))?;
    if corners.len() < MIN_TRACKED {
        return Ok(own.to_vec());
    }
    let mut warped: Vec<(Mat, Mat)> = Vec::new();
    for step in COMPENSATED_STEPS {
        let Some(other) = index.checked_add_signed(step as isize).and_then(|k| gray.get(k)) else { continue };
        if let Some(pair) = warp_onto(other, frame, &corners, size)? {
            warped.push(pair);
        }
    }
    if warped.len() < MIN_COVERING_FRAMES {
        return Ok(own.to_vec());
    }
    let mut values = Vec::with_capacity(warped.len());
    let mut covers = Vec::with_capacity(warped.len());
    for (image, valid) in &warped {
        values.push(image.data_bytes().map_err(SfmError::cv("warped frame"))?);
        covers.push(valid.data_bytes().map_err(SfmError::cv("warped frame"))?);
    }
    Ok(pixel_medians(&values, Some(&covers), Some(own)))
}

/// `other` warped onto `frame` by the homography of `corners` (in `frame`) tracked into it, and
/// where the warp covers `frame` (255); `None` when too few corners follow one homography.
fn warp_onto(other: &Mat, frame: &Mat, corners: &Vector<Point2f>, size: Size) -> SfmResult<Option<(Mat, Mat)>> {
    let Some(h) = tracked_homography(frame, other, corners)? else { return Ok(None) };
    let warp = |src: &Mat, interpolation: i32| -> SfmResult<Mat> {
        let mut out = Mat::default();
        imgproc::warp_perspective(src, &mut out, &h, size, interpolation, core::BORDER_CONSTANT, Scalar::all(0.0))
            .map_err(SfmError::cv("warping a frame"))?;
        Ok(out)
    };
    let ones = Mat::new_size_with_default(other.size().map_err(SfmError::cv("frame size"))?, core::CV_8UC1, Scalar::all(255.0))
        .map_err(SfmError::cv("coverage"))?;
    Ok(Some((warp(other, imgproc::INTER_LINEAR)?, warp(&ones, imgproc::INTER_NEAREST)?)))
}

/// The homography taking `other`'s pixels onto `frame`'s, from `corners` (in `frame`) tracked
/// into `other` (RANSAC: what moves is left out); `None` when too few corners follow one.
fn tracked_homography(frame: &Mat, other: &Mat, corners: &Vector<Point2f>) -> SfmResult<Option<Mat>> {
    let (mut tracked, mut status, mut error) = (Vector::<Point2f>::new(), Vector::<u8>::new(), Vector::<f32>::new());
    let criteria = TermCriteria::new(core::TermCriteria_COUNT + core::TermCriteria_EPS, 30, 0.01).map_err(SfmError::cv("criteria"))?;
    video::calc_optical_flow_pyr_lk(frame, other, corners, &mut tracked, &mut status, &mut error, Size::new(21, 21), 3, criteria, 0, 1e-4)
        .map_err(SfmError::cv("tracking corners"))?;
    let (mut from, mut to) = (Vector::<Point2f>::new(), Vector::<Point2f>::new());
    for k in 0..corners.len() {
        if status.get(k).map_err(SfmError::cv("track status"))? == 1 {
            from.push(tracked.get(k).map_err(SfmError::cv("tracked corner"))?);
            to.push(corners.get(k).map_err(SfmError::cv("corner"))?);
        }
    }
    if from.len() < MIN_TRACKED {
        return Ok(None);
    }
    let mut inliers = Mat::default();
    let h = calib3d::find_homography_ext(&from, &to, calib3d::RANSAC, HOMOGRAPHY_PX, &mut inliers, 2000, 0.995)
        .map_err(SfmError::cv("background homography"))?;
    let kept = if inliers.empty() { 0 } else { core::count_non_zero(&inliers).map_err(SfmError::cv("homography inliers"))? as usize };
    Ok((h.rows() == 3 && h.cols() == 3 && kept >= MIN_TRACKED).then_some(h))
}

/// Per pixel, the median of `images`' values: of those `covers` marks where given, and
/// `fallback`'s value where fewer than [`MIN_COVERING_FRAMES`] cover it.
fn pixel_medians(images: &[&[u8]], covers: Option<&[&[u8]]>, fallback: Option<&[u8]>) -> Vec<u8> {
    let len = images.first().map_or(0, |p| p.len());
    let mut column = Vec::with_capacity(images.len());
    (0..len)
        .map(|i| {
            column.clear();
            column.extend(images.iter().enumerate().filter(|(k, _)| covers.is_none_or(|c| c[*k][i] != 0)).map(|(_, p)| p[i]));
            if let Some(own) = fallback.filter(|_| column.len() < MIN_COVERING_FRAMES) {
                return own[i];
            }
            if column.is_empty() {
                return 0;
            }
            column.sort_unstable();
            column[column.len() / 2]
        })
        .collect()
}

/// Where `gray` differs from the still image by more than `threshold` grey levels, grown by a
/// few pixels (8-bit, 255 = moving).
pub fn moving_mask(gray: &Mat, still: &[u8], threshold: f64) -> SfmResult<Mat> {
    let bytes = gray.data_bytes().map_err(SfmError::cv("frame bytes"))?;
    let moving: Vec<u8> = bytes.iter().zip(still).map(|(g, s)| if f64::from(g.abs_diff(*s)) > threshold { 255 } else { 0 }).collect();
    let mask = Mat::new_rows_cols_with_data(gray.rows(), gray.cols(), &moving)
        .map_err(SfmError::cv("moving mask"))?
        .try_clone()
        .map_err(SfmError::cv("moving mask"))?;
    let kernel =
        imgproc::get_structuring_element(imgproc::MORPH_ELLIPSE, Size::new(7, 7), Point::new(-1, -1)).map_err(SfmError::cv("kernel"))?;
    let mut grown = Mat::default();
    imgproc::dilate(
        &mask,
        &mut grown,
        &kernel,
        Point::new(-1, -1),
        1,
        core::BORDER_CONSTANT,
        imgproc::morphology_default_border_value().map_err(SfmError::cv("border"))?,
    )
    .map_err(SfmError::cv("growing the moving mask"))?;
    Ok(grown)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Smooth random blobs: random grey levels on a 5 px grid, interpolated.
    fn blobs(x: i32, y: i32) -> u8 {
        let level = |gx: i32, gy: i32| {
            let h = (gx.wrapping_mul(73_856_093) ^ gy.wrapping_mul(19_349_663)).wrapping_mul(83_492_791) as u32;
            f64::from(h >> 24)
        };
        let (gx, gy, fx, fy) = (x.div_euclid(5), y.div_euclid(5), f64::from(x.rem_euclid(5)) / 5.0, f64::from(y.rem_euclid(5)) / 5.0);
        let top = level(gx, gy) * (1.0 - fx) + level(gx + 1, gy) * fx;
        let bottom = level(gx, gy + 1) * (1.0 - fx) + level(gx + 1, gy + 1) * fx;
        ((top * (1.0 - fy) + bottom * fy) * 0.8) as u8
    }

    /// A textured background shifted by `dx` px, with a bright square at `square_x`.
    fn frame(dx: i32, square_x: i32) -> Mat {
        let (w, h) = (160, 120);
        let mut data = vec![0u8; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let texture = blobs(x + dx, y);
                let inside = (square_x..square_x + 12).contains(&x) && (50..62).contains(&y);
                data[(y * w + x) as usize] = if inside { 255 } else { texture };
            }
        }
        Mat::new_rows_cols_with_data(h, w, &data).unwrap().try_clone().unwrap()
    }

    #[test]
    fn a_panning_cameras_still_image_keeps_the_background_and_drops_what_moves() {
        // The camera pans 1 px a frame; a square crosses the scene 4 px a frame.
        let gray: Vec<Mat> = (0..25).map(|k| frame(k, 10 + 5 * k)).collect();
        let index = 12;
        let still = compensated_still(&gray, index).unwrap();
        let mask = moving_mask(&gray[index], &still, 25.0).unwrap();
        let m = mask.data_bytes().unwrap();
        let w = 160;
        // The square (at x 70..82) is found moving, the background away from it and from the
        // borders the warps leave uncovered is not.
        assert_eq!(m[56 * w + 76], 255, "the square's middle moves");
        let background_moving = (20..100)
            .flat_map(|y| (20..140).map(move |x| (x, y)))
            .filter(|&(x, y)| !(60..92).contains(&x) || !(40..72).contains(&y))
            .filter(|&(x, y)| m[y * w + x] != 0)
            .count();
        assert!(background_moving < 40, "{background_moving} background pixels marked moving");
        // The plain median over the recording marks the panned background as moving.
        let blurred = median_image(&gray, 15).unwrap();
        let plain = moving_mask(&gray[index], &blurred, 25.0).unwrap();
        let p = plain.data_bytes().unwrap();
        let plain_moving = (20..100).flat_map(|y| (20..140).map(move |x| (x, y))).filter(|&(x, y)| p[y * w + x] != 0).count();
        assert!(plain_moving > 1000, "the plain median marks {plain_moving}");
    }
}
