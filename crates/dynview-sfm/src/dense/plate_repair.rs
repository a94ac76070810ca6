//! Plates repaired from the static scene other cameras see (issue 33).
//!
//! A plate pixel is the colour seen longest. Where someone stood in front of the background for
//! longer than the background was seen (in a short event, a person who stays a second), the
//! plate shows that person, and the renderer paints them onto the static surface wherever that
//! view is used for it. The background is usually still among the pixel's other colour modes
//! ([`Plate::others`]); what tells it apart is the static cloud: the points other cameras see on
//! their plates, projected into this camera, give the colour its plate should show.
//!
//! Per camera: the static points seen by at least two *other* cameras are z-buffered into it
//! (a pixel no point lands on takes the nearest of those on the 3x3 pixels around it); their
//! colours are mapped into the camera's own response by an affine map per channel fitted where
//! its plate is sure; where the plate's colour differs from the point's by more than the
//! tolerance, no point within 2 pixels shows the plate's colour (a seam or a dot that the points
//! fall just beside is right as it is), and another mode, seen for at least `min_share` of the
//! frames, matches the point (within the tolerance and better), that mode becomes the plate's
//! colour and its share the confidence. Nothing else changes: a static thing that
//! only this camera sees (no point) or that stood all event (no other mode) stays as it is.

use dynview_core::Camera;
use dynview_core::scene::PointCloud;
use glam::DVec3;

use super::plates::{Plate, PlateMode};
use super::static_cloud::difference;

/// Plate confidence from which a pixel counts as sure when fitting the colour map.
const SURE_CONFIDENCE: f32 = 0.8;
/// Fewest sure pixels with a point for a colour map to be fitted (else nothing is repaired).
const MIN_FIT_PIXELS: usize = 100;
/// Pixels on either side of a pixel over which a point stands for it when none lands on it.
const FOOTPRINT_PX: usize = 1;
/// Pixels on either side of a pixel within which a point of the plate's own colour means the
/// plate is right there (a thin seam or a dot the points fall just beside).
const AGREE_PX: usize = 2;

/// Repairs `plate` (of `camera`, which stands still) from `points` (static, with colours), of
/// which only those where `seen_elsewhere(i)` count; returns the pixels changed. `min_share`: the
/// least share of the frames another mode must have been seen; `tolerance`: mean absolute RGB
/// difference (colours in `[0, 1]`) within which colours match.
pub fn repair_plate(
    plate: &mut Plate,
    camera: &Camera,
    points: &PointCloud,
    seen_elsewhere: impl Fn(usize) -> bool,
    min_share: f32,
    tolerance: f32,
) -> usize {
    let (w, h) = (plate.image.width() as usize, plate.image.height() as usize);
    if plate.others_per_pixel() == 0 || w * h != plate.confidence.len() {
        return 0;
    }
    let exact = nearest_points(camera, points, &seen_elsewhere, w, h);
    let nearest: Vec<Option<usize>> = (0..w * h).map(|p| exact[p].map(|(i, _)| i).or_else(|| nearest_around(&exact, p, w, h))).collect();
    let pairs: Vec<([f32; 3], [f32; 3])> = (0..w * h)
        .filter(|&p| plate.confidence[p] >= SURE_CONFIDENCE)
        .filter_map(|p| nearest[p].map(|i| (unit(points.colors[i]), unit(pixel(plate, p)))))
        .collect();
    let Some(map) = ColorMap::fit_robust(&pairs, tolerance) else { return 0 };
    let mut changed = 0;
    for (p, near) in nearest.iter().enumerate() {
        let Some(i) = *near else { continue };
        let expected = map.apply(unit(points.colors[i]));
        let shown = unit(pixel(plate, p));
        let lead = difference(shown, expected);
        if lead <= tolerance
            || window(p, w, h, AGREE_PX)
                .any(|q| exact[q].is_some_and(|(j, _)| difference(shown, map.apply(unit(points.colors[j]))) <= tolerance))
        {
            continue;
        }
        let best = plate
            .others_at(p)
            .iter()
            .enumerate()
            .filter(|(_, m)| m.share >= min_share)
            .map(|(k, m)| (k, difference(unit(m.color), expected)))
            .filter(|&(_, d)| d <= tolerance && d < lead)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((k, _)) = best {
            let per_pixel = plate.others_per_pixel();
            let old = PlateMode { color: pixel(plate, p), share: plate.confidence[p] };
            let new = std::mem::replace(&mut plate.others[p * per_pixel + k], old);
            // The others stay most seen first.
            plate.others[p * per_pixel..(p + 1) * per_pixel].sort_by(|a, b| b.share.total_cmp(&a.share));
            plate.image.get_pixel_mut((p % w) as u32, (p / w) as u32).0 = new.color;
            plate.confidence[p] = new.share;
            changed += 1;
        }
    }
    changed
}

/// Per pixel of a `w` x `h` camera, the nearest of the points that count landing on it, and
/// its z-depth.
fn nearest_points(camera: &Camera, points: &PointCloud, counts: &impl Fn(usize) -> bool, w: usize, h: usize) -> Vec<Option<(usize, f64)>> {
    let mut nearest: Vec<Option<(usize, f64)>> = vec![None; w * h];
    for (i, p) in points.positions_world.iter().enumerate() {
        if !counts(i) {
            continue;
        }
        let Some((pixel, z)) = camera.project_world(to_world(*p)) else { continue };
        let (x, y) = (pixel.x.round(), pixel.y.round());
        if x < 0.0 || y < 0.0 || x >= w as f64 || y >= h as f64 {
            continue;
        }
        let q = y as usize * w + x as usize;
        if nearest[q].is_none_or(|(_, depth)| z < depth) {
            nearest[q] = Some((i, z));
        }
    }
    nearest
}

/// The nearest to the camera of the points on the pixels within [`FOOTPRINT_PX`] of `p`.
fn nearest_around(exact: &[Option<(usize, f64)>], p: usize, w: usize, h: usize) -> Option<usize> {
    window(p, w, h, FOOTPRINT_PX).filter_map(|q| exact[q]).min_by(|a, b| a.1.total_cmp(&b.1)).map(|(i, _)| i)
}

/// Row-major pixels within `radius` of pixel `p` (inside the `w` x `h` image).
fn window(p: usize, w: usize, h: usize, radius: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (p % w, p / w);
    let (x0, x1, y0, y1) = (x.saturating_sub(radius), (x + radius).min(w - 1), y.saturating_sub(radius), (y + radius).min(h - 1));
    (y0..=y1).flat_map(move |v| (x0..=x1).map(move |u| v * w + u))
}

fn to_world(p: [f32; 3]) -> DVec3 {
    DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
}

/// The plate's colour at row-major pixel `p`.
fn pixel(plate: &Plate, p: usize) -> [u8; 3] {
    let w = plate.image.width() as usize;
    plate.image.get_pixel((p % w) as u32, (p / w) as u32).0
}

fn unit(c: [u8; 3]) -> [f32; 3] {
    c.map(|v| f32::from(v) / 255.0)
}

/// Per channel `gain * colour + offset`: another camera's colours in this camera's response.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ColorMap {
    gain: [f32; 3],
    offset: [f32; 3],
}

impl ColorMap {
    /// Least squares over `(from, to)` pairs, fitted again twice on the pairs it maps within
    /// `tolerance` (a thin seam, or a point a pixel off an edge, does not bend it); `None` as
    /// [`ColorMap::fit`].
    fn fit_robust(pairs: &[([f32; 3], [f32; 3])], tolerance: f32) -> Option<Self> {
        let mut map = Self::fit(pairs)?;
        for _ in 0..2 {
            let inliers: Vec<_> = pairs.iter().copied().filter(|&(from, to)| difference(map.apply(from), to) <= tolerance).collect();
            map = Self::fit(&inliers)?;
        }
        Some(map)
    }

    /// Least squares over `(from, to)` pairs; `None` with fewer than [`MIN_FIT_PIXELS`] or a
    /// channel without spread.
    fn fit(pairs: &[([f32; 3], [f32; 3])]) -> Option<Self> {
        if pairs.len() < MIN_FIT_PIXELS {
            return None;
        }
        let n = pairs.len() as f64;
        let mut map = ColorMap { gain: [1.0; 3], offset: [0.0; 3] };
        for k in 0..3 {
            let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
            for (from, to) in pairs {
                let (x, y) = (f64::from(from[k]), f64::from(to[k]));
                sx += x;
                sy += y;
                sxx += x * x;
                sxy += x * y;
            }
            let var = sxx - sx * sx / n;
            if var <= 1e-9 * n {
                return None;
            }
            let gain = (sxy - sx * sy / n) / var;
            map.gain[k] = gain as f32;
            map.offset[k] = ((sy - gain * sx) / n) as f32;
        }
        Some(map)
    }

    fn apply(&self, c: [f32; 3]) -> [f32; 3] {
        std::array::from_fn(|k| (self.gain[k] * c[k] + self.offset[k]).clamp(0.0, 1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dense::plates::{PlateEstimator, PlateOptions};
    use dynview_core::{Intrinsics, Rigid3};
    use glam::DMat3;

    const W: u32 = 64;
    const H: u32 = 48;
    const WALL: [u8; 3] = [200, 190, 170];
    const SHIRT: [u8; 3] = [40, 40, 90];

    fn camera() -> Camera {
        Camera {
            intrinsics: Intrinsics { fx: 60.0, fy: 60.0, cx: 31.5, cy: 23.5 },
            camera_from_world: Rigid3::new(DMat3::IDENTITY, DVec3::ZERO),
            width_px: W,
            height_px: H,
        }
    }

    /// A wall at z = 4 whose brightness varies across it, one point per pixel, in the colours
    /// of another camera (a darker response: `0.8 * c + 10`).
    fn wall_points() -> PointCloud {
        let mut cloud = PointCloud::default();
        let cam = camera();
        for v in 0..H {
            for u in 0..W {
                let p = cam.unproject_world(glam::DVec2::new(f64::from(u), f64::from(v)), 4.0);
                cloud.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
                cloud.colors.push(wall_at(u).map(|c| (0.8 * f32::from(c) + 10.0) as u8));
            }
        }
        cloud
    }

    fn wall_at(u: u32) -> [u8; 3] {
        WALL.map(|c| c - (u as u8 / 2))
    }

    /// Frames of a camera that sees the wall, with someone standing in the block
    /// x 20..36, y 10..40 for `stay` of `frames` frames.
    fn plate(stay: usize, frames: usize) -> Plate {
        let mut estimator = PlateEstimator::new(W, H, PlateOptions::default()).expect("estimator");
        for f in 0..frames {
            let frame = image::RgbImage::from_fn(W, H, |u, v| {
                let inside = (20..36).contains(&u) && (10..40).contains(&v);
                image::Rgb(if inside && f < stay { SHIRT } else { wall_at(u) })
            });
            estimator.push(&frame).expect("size");
        }
        estimator.plate()
    }

    #[test]
    fn someone_who_stood_longer_than_the_wall_was_seen_is_replaced_by_the_wall() {
        let mut plate = plate(45, 75);
        assert_eq!(plate.image.get_pixel(28, 25).0, SHIRT, "the plate shows whoever stood longest");
        let changed = repair_plate(&mut plate, &camera(), &wall_points(), |_| true, 0.15, 0.1);
        assert_eq!(changed, 16 * 30, "every pixel of the block and nothing else");
        for v in 0..H {
            for u in 0..W {
                assert_eq!(plate.image.get_pixel(u, v).0, wall_at(u), "pixel ({u}, {v})");
            }
        }
        assert!((plate.confidence[25 * W as usize + 28] - 0.4).abs() < 1e-6, "its share becomes the confidence");
        let others = plate.others_at(25 * W as usize + 28);
        assert_eq!(others[0].color, SHIRT, "the person stays among the other modes, most seen first");
        assert!(others.windows(2).all(|w| w[0].share >= w[1].share));
    }

    #[test]
    fn nothing_changes_without_another_mode_points_or_a_long_enough_glimpse() {
        // Stood all event: no other mode to take.
        let mut always = plate(75, 75);
        assert_eq!(repair_plate(&mut always, &camera(), &wall_points(), |_| true, 0.15, 0.1), 0);
        // The wall seen for 4 frames of 75: below the share asked.
        let mut glimpse = plate(71, 75);
        assert_eq!(repair_plate(&mut glimpse, &camera(), &wall_points(), |_| true, 0.15, 0.1), 0);
        // No point seen by other cameras.
        let mut unseen = plate(45, 75);
        let before = unseen.clone();
        assert_eq!(repair_plate(&mut unseen, &camera(), &wall_points(), |_| false, 0.15, 0.1), 0);
        assert_eq!(unseen, before);
    }

    #[test]
    fn a_seam_the_points_fall_beside_is_kept() {
        // A dark seam on column 10, shown in 60 frames of 75 (the wall in the others: the camera
        // shook); the points of the seam landed one pixel beside it, on column 11.
        const SEAM: [u8; 3] = [30, 30, 35];
        let mut estimator = PlateEstimator::new(W, H, PlateOptions::default()).expect("estimator");
        for f in 0..75 {
            let frame = image::RgbImage::from_fn(W, H, |u, _| image::Rgb(if u == 10 && f < 60 { SEAM } else { wall_at(u) }));
            estimator.push(&frame).expect("size");
        }
        let mut plate = estimator.plate();
        let mut points = wall_points();
        for v in 0..H as usize {
            points.colors[v * W as usize + 11] = SEAM.map(|c| (0.8 * f32::from(c) + 10.0) as u8);
            points.colors[v * W as usize + 10] = [0; 3];
        }
        let on_seam = |i: usize| i % W as usize != 10;
        let before = plate.clone();
        assert_eq!(repair_plate(&mut plate, &camera(), &points, on_seam, 0.15, 0.1), 0);
        assert_eq!(plate, before);
    }
}
