//! The static cloud from background plates (issue 33): for an event whose cameras stand still,
//! PatchMatch stereo on the cameras' [plates](super::plates) rather than on single frames
//! (no moving people to confuse matching, the noise of many frames averaged away), lent to each
//! step where the step's frames still show the plate.
//!
//! 1. A plate per camera that stands still, from every step's working frame (streaming,
//!    [`super::plates::PlateEstimator`]).
//! 2. [`super::densify::densify`] on the plates, seeded with the static points found across time
//!    (they give each view its depth range), at the working size and with more source views and
//!    points than a time step gets: it runs once per event.
//! 3. A camera *sees* a dense point when the point lands inside its plate where the plate is
//!    confident ([`PlateCloudOptions::min_confidence`]) and shows the point's color
//!    ([`PlateCloudOptions::seen_tolerance`]); a point seen by fewer than two cameras is dropped.
//!    With [`PlateCloudOptions::drop_contradicted`], so is a point that as many cameras
//!    contradict: it lands inside their plate where it is confident, in front of every other
//!    dense point there, and the plate shows another colour (stereo matched a pattern at the
//!    wrong depth, and the cameras that look through the point see the wall behind it).
//! 4. The point is lent to step `t` where most of the cameras that see it, and at least two,
//!    show their plate's color there in the step's frame ([`PlateCloudOptions::color_tolerance`]):
//!    where something moved in front of it, the step's own points stand instead.
//!
//! 5. Before step 3 counts, each plate is repaired where someone stood in front of the
//!    background longer than it was seen ([`super::plate_repair`], [`PlateCloudOptions::repair_min_share`]):
//!    the points the other cameras see give the colour it should show.
//!
//! Colors are compared within one camera (frame against that camera's plate), so exposure and
//! white balance that differ between cameras do not matter.

use dynview_camera::Radial;
use dynview_core::Camera;
use dynview_core::raster::ScalarRaster;
use dynview_core::scene::PointCloud;
use glam::DVec3;
use nalgebra::Vector3;
use opencv::core::{Mat, Vec3b};
use opencv::prelude::*;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::densify::{DensifyOptions, densify};
use super::free_space::static_depth_map;
use super::plate_repair::repair_plate;
use super::plates::{Plate, PlateEstimator, PlateOptions};
use super::static_cloud::{StaticCloud, StepFrames, agreeing_cameras, difference, sample};
use crate::error::{SfmError, SfmResult};
use crate::mapping::points::{TimestepCloud, TimestepView};

/// How the static cloud is grown from the plates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlateCloudOptions {
    /// How each camera's plate is estimated.
    pub plates: PlateOptions,
    /// PatchMatch on the plates.
    pub densify: DensifyOptions,
    /// Smallest plate confidence (share of the frames that showed the plate's color) at which a
    /// camera counts as seeing a point.
    pub min_confidence: f32,
    /// Largest mean absolute RGB difference (colors in `[0, 1]`) between a point's color and a
    /// camera's plate where it lands for the camera to count as seeing it.
    pub seen_tolerance: f32,
    /// Largest mean absolute RGB difference between a step's frame and the plate for a camera to
    /// agree, at that step, that nothing stands in front of the point.
    pub color_tolerance: f32,
    /// Voxel edge in pixels of the first camera at the points' median depth: the step's own
    /// points in or next to the voxel of a lent point are left to it.
    pub voxel_px: f64,
    /// Least share of the frames in which a plate pixel's other colour must have been seen for
    /// it to replace the plate's where the points other cameras see show that colour (0 turns
    /// the repair off; [`super::plate_repair`]).
    pub repair_min_share: f32,
    /// Drop a dense point that at least as many cameras contradict as see it (the module's
    /// step 3).
    pub drop_contradicted: bool,
}

impl Default for PlateCloudOptions {
    fn default() -> Self {
        Self {
            plates: PlateOptions::default(),
            densify: DensifyOptions {
                target_points: 200_000,
                max_side_px: 960,
                source_views: 4,
                best_sources: 2,
                consistent_views_where_matched: 3,
                ..DensifyOptions::default()
            },
            min_confidence: 0.5,
            seen_tolerance: 0.1,
            color_tolerance: 0.06,
            voxel_px: 2.0,
            repair_min_share: 0.15,
            drop_contradicted: false,
        }
    }
}

/// Whether camera `c` (`cameras[c][t]`) stands still: the same pose and intrinsics at every step.
pub fn stands_still(steps: &[Camera]) -> bool {
    steps.windows(2).all(|w| w[0] == w[1])
}

/// The plate of every camera that stands still (`None` for the others), from the frames of every
/// step (`frames_at(t)`: one per camera, the cameras' working size), read one step at a time.
pub fn estimate_plates(
    cameras: &[Vec<Camera>],
    frames_at: impl Fn(usize) -> SfmResult<StepFrames>,
    options: &PlateOptions,
) -> SfmResult<Vec<Option<Plate>>> {
    let steps = cameras.first().map_or(0, Vec::len);
    let mut estimators: Vec<Option<PlateEstimator>> = cameras
        .iter()
        .map(|c| match c.first().filter(|_| stands_still(c)) {
            Some(camera) => PlateEstimator::new(camera.width_px, camera.height_px, options.clone()).map(Some),
            None => Ok(None),
        })
        .collect::<SfmResult<_>>()?;
    if estimators.iter().all(Option::is_none) {
        return Ok(vec![None; cameras.len()]);
    }
    for t in 0..steps {
        let frames = frames_at(t)?;
        for (estimator, frame) in estimators.iter_mut().zip(&frames) {
            if let Some(estimator) = estimator {
                estimator.push(frame)?;
            }
        }
    }
    Ok(estimators.into_iter().map(|e| e.map(|e| e.plate())).collect())
}

/// An RGB image as an 8-bit BGR matrix, as OpenCV and densification read frames.
fn bgr_mat(image: &image::RgbImage) -> SfmResult<Mat> {
    let pixels: Vec<Vec3b> = image.pixels().map(|p| Vec3b::from([p[2], p[1], p[0]])).collect();
    let mat = Mat::new_rows_cols_with_data(image.height() as i32, image.width() as i32, &pixels).map_err(SfmError::cv("plate matrix"))?;
    mat.try_clone().map_err(SfmError::cv("plate matrix"))
}

/// The static cloud grown from `plates` (one per camera, `None` for a camera that moves), seeded
/// with `seeds` (static points: each view's depth range and first guesses), and lent to every step
/// whose frames (`frames_at`) agree with the plates there. `None` when fewer than two cameras have
/// a plate. The plates are repaired on the way ([`PlateCloudOptions::repair_min_share`]); the
/// cloud's `repaired_plate_pixels` counts the pixels changed.
pub fn plate_cloud(
    cameras: &[Vec<Camera>],
    plates: &mut [Option<Plate>],
    seeds: &PointCloud,
    frames_at: impl Fn(usize) -> SfmResult<StepFrames> + Sync,
    options: &PlateCloudOptions,
) -> SfmResult<Option<StaticCloud>> {
    let with_plate: Vec<usize> =
        (0..cameras.len()).filter(|&c| plates.get(c).is_some_and(Option::is_some) && !cameras[c].is_empty()).collect();
    if with_plate.len() < 2 || seeds.is_empty() {
        return Ok(None);
    }
    let steps = cameras[0].len();
    let mats: Vec<Mat> = with_plate.iter().map(|&c| bgr_mat(&plate_of(plates, c).image)).collect::<SfmResult<_>>()?;
    let views: Vec<TimestepView> = with_plate
        .iter()
        .zip(&mats)
        .map(|(&c, mat)| {
            let camera = &cameras[c][0];
            TimestepView { intrinsics: Radial::from_pinhole(&camera.intrinsics.into()), pose: camera.camera_from_world, image_bgr: mat }
        })
        .collect();
    let sparse = TimestepCloud {
        positions_world: seeds.positions_world.iter().map(|p| Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))).collect(),
        colors: seeds.colors.clone(),
        views: vec![2; seeds.len()],
    };
    let dense = densify(&views, &sparse, &options.densify)?;
    let count = cameras.len();
    let mut kept = seen_points(cameras, plates, &dense.positions_world, &dense.colors, options);
    let mut out = StaticCloud::default();
    if options.repair_min_share > 0.0 {
        for &c in &with_plate {
            let seen_elsewhere = |i: usize| (0..count).filter(|&o| o != c && kept.shown[i * count + o].is_some()).count() >= 2;
            let plate = plates[c].as_mut().expect("cameras with a plate only");
            out.repaired_plate_pixels +=
                repair_plate(plate, &cameras[c][0], &kept.points, seen_elsewhere, options.repair_min_share, options.seen_tolerance);
        }
        if out.repaired_plate_pixels > 0 {
            kept = seen_points(cameras, plates, &dense.positions_world, &dense.colors, options);
        }
    }
    let Kept { points, shown: own, seen } = kept;
    out.points = points;
    out.candidates = dense.positions_world.len();
    out.voxel_edge = voxel_edge(cameras, &out.points, options.voxel_px);
    let at_step = |t: usize| -> Vec<Camera> { cameras.iter().map(|c| c[t]).collect() };
    out.active = (0..steps)
        .into_par_iter()
        .map(|t| {
            let frames = frames_at(t)?;
            let at_t = at_step(t);
            Ok((0..out.points.len())
                .filter(|&i| {
                    let p = out.points.positions_world[i];
                    let p = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
                    let agree = agreeing_cameras(p, &own[i * count..(i + 1) * count], &at_t, &frames, options.color_tolerance);
                    agree >= 2 && 3 * agree >= 2 * seen[i]
                })
                .map(|i| i as u32)
                .collect())
        })
        .collect::<SfmResult<_>>()?;
    Ok(Some(out))
}

/// The dense points seen by two cameras or more, with per point and camera the plate's colour
/// where a camera sees it (`shown[i * cameras + c]`) and how many do.
struct Kept {
    points: PointCloud,
    shown: Vec<Option<[f32; 3]>>,
    seen: Vec<usize>,
}

/// A dense point kept: where it is, its colour, and per camera the plate's colour where seen.
type SeenPoint = (DVec3, [u8; 3], Vec<Option<[f32; 3]>>);

/// A camera *sees* a point where it lands inside its plate, the plate is confident and shows
/// the point's colour; the points seen by fewer than two cameras are dropped, and with
/// [`PlateCloudOptions::drop_contradicted`] those that as many cameras contradict (the plate is
/// confident there and shows another colour, and no other dense point stands in front).
fn seen_points(
    cameras: &[Vec<Camera>],
    plates: &[Option<Plate>],
    positions: &[Vector3<f64>],
    colors: &[[u8; 3]],
    options: &PlateCloudOptions,
) -> Kept {
    let nearest_depth_m = options.drop_contradicted.then(|| nearest_depth_maps(cameras, plates, positions, colors));
    // Per camera the plate's colour where it sees the point, and how many contradict it.
    let look = |p: DVec3, color: [u8; 3]| -> (Vec<Option<[f32; 3]>>, usize) {
        let color = color.map(|v| f32::from(v) / 255.0);
        let mut contradicted = 0;
        let shown = (0..cameras.len())
            .map(|c| {
                let plate = plates.get(c)?.as_ref()?;
                let (pixel, depth_m) = cameras[c].first()?.project_world(p)?;
                let index = nearest_index(&plate.image, pixel.x, pixel.y)?;
                let shown = sample(&plate.image, pixel.x, pixel.y)?;
                if plate.confidence[index] < options.min_confidence {
                    return None;
                }
                if difference(shown, color) <= options.seen_tolerance {
                    return Some(shown);
                }
                let nearest = nearest_depth_m.as_ref().and_then(|maps| maps[c].as_ref());
                if nearest.is_some_and(|nearest| depth_m <= f64::from(nearest.data[index]) * (1.0 + IN_FRONT_SHARE)) {
                    contradicted += 1;
                }
                None
            })
            .collect();
        (shown, contradicted)
    };
    let per_point: Vec<SeenPoint> = positions
        .par_iter()
        .zip(colors)
        .filter_map(|(position, &color)| {
            let p = DVec3::new(position.x, position.y, position.z);
            let (shown, contradicted) = look(p, color);
            let seen = shown.iter().filter(|s| s.is_some()).count();
            (seen >= 2 && contradicted < seen).then_some((p, color, shown))
        })
        .collect();
    let mut kept = Kept { points: PointCloud::default(), shown: Vec::new(), seen: Vec::new() };
    for (p, color, shown) in per_point {
        kept.points.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
        kept.points.colors.push(color);
        kept.seen.push(shown.iter().filter(|s| s.is_some()).count());
        kept.shown.extend(shown);
    }
    kept
}

/// A point counts as in front of every other dense point where its depth is within this share
/// of the nearest one's.
const IN_FRONT_SHARE: f64 = 0.05;

/// Radius (px) over which each dense point covers a camera's nearest-depth map.
const CONTRADICTION_FOOTPRINT_PX: usize = 2;

/// Per camera with a plate, the depth of the nearest dense point at each pixel: what a camera
/// contradicts a point with ([`PlateCloudOptions::drop_contradicted`]).
fn nearest_depth_maps(
    cameras: &[Vec<Camera>],
    plates: &[Option<Plate>],
    positions: &[Vector3<f64>],
    colors: &[[u8; 3]],
) -> Vec<Option<ScalarRaster>> {
    let cloud =
        PointCloud { positions_world: positions.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(), colors: colors.to_vec() };
    (0..cameras.len())
        .map(|c| {
            let camera = cameras[c].first().filter(|_| plates.get(c).is_some_and(Option::is_some))?;
            Some(static_depth_map(camera, &cloud, CONTRADICTION_FOOTPRINT_PX))
        })
        .collect()
}

fn plate_of(plates: &[Option<Plate>], c: usize) -> &Plate {
    plates[c].as_ref().expect("cameras with a plate only")
}

/// Row-major index of the pixel nearest `(x, y)` inside `image`.
fn nearest_index(image: &image::RgbImage, x: f64, y: f64) -> Option<usize> {
    let (x, y) = (x.round(), y.round());
    (x >= 0.0 && y >= 0.0 && x < f64::from(image.width()) && y < f64::from(image.height()))
        .then(|| y as usize * image.width() as usize + x as usize)
}

/// `voxel_px` pixels of the first camera at the points' median depth (0 without points).
fn voxel_edge(cameras: &[Vec<Camera>], points: &PointCloud, voxel_px: f64) -> f64 {
    let Some(camera) = cameras.first().and_then(|c| c.first()) else { return 0.0 };
    let mut depths: Vec<f64> = points
        .positions_world
        .iter()
        .map(|p| camera.camera_from_world.transform_point(DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))).z.abs())
        .collect();
    if depths.is_empty() {
        return 0.0;
    }
    depths.sort_by(f64::total_cmp);
    (depths[depths.len() / 2] * voxel_px / camera.intrinsics.fx.max(1e-9)).max(1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_core::{Intrinsics, Rigid3};
    use glam::{DMat3, DVec2};

    const STEPS: usize = 6;
    const OCCLUDED_STEP: usize = 3;
    const WALL_Z: f64 = 5.0;
    /// Where a dark thing stands in front of the wall at [`OCCLUDED_STEP`] (on the wall).
    const OCCLUDED: DVec3 = DVec3::new(0.0, 0.0, WALL_Z);

    fn camera(x_m: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics { fx: 80.0, fy: 80.0, cx: 47.5, cy: 35.5 },
            camera_from_world: Rigid3::new(DMat3::IDENTITY, DVec3::new(-x_m, 0.0, 0.0)),
            width_px: 96,
            height_px: 72,
        }
    }

    /// A textured wall (z = 5): smooth noise of a few frequencies, so that stereo matches it.
    fn wall_color(p: DVec3) -> image::Rgb<u8> {
        let v = 0.5 + 0.2 * (7.0 * p.x).sin() * (5.0 * p.y).cos() + 0.15 * (13.0 * p.x + 3.0 * p.y).sin() + 0.1 * (17.0 * p.y).sin();
        let g = (255.0 * v.clamp(0.0, 1.0)).round() as u8;
        image::Rgb([g, g / 2 + 60, 255 - g])
    }

    /// Cameras `[camera][step]` (three that stand still) and frames `[step][camera]`.
    fn event() -> (Vec<Vec<Camera>>, Vec<StepFrames>) {
        let cameras: Vec<Camera> = [-0.4, 0.0, 0.4].into_iter().map(camera).collect();
        let frames = (0..STEPS)
            .map(|t| {
                cameras
                    .iter()
                    .map(|camera| {
                        let hidden = camera.project_world(OCCLUDED).map(|(q, _)| q).unwrap_or_default();
                        image::RgbImage::from_fn(96, 72, |u, v| {
                            let pixel = DVec2::new(f64::from(u), f64::from(v));
                            if t == OCCLUDED_STEP && pixel.distance(hidden) <= 6.0 {
                                return image::Rgb([10, 10, 10]);
                            }
                            wall_color(camera.unproject_world(pixel, WALL_Z))
                        })
                    })
                    .collect()
            })
            .collect();
        (cameras.into_iter().map(|c| vec![c; STEPS]).collect(), frames)
    }

    #[test]
    fn the_plates_give_a_dense_wall_lent_except_where_something_stands_in_front() {
        let (cameras, frames) = event();
        let options = PlateCloudOptions::default();
        let mut plates = estimate_plates(&cameras, |t| Ok(frames[t].clone()), &options.plates).expect("in memory");
        assert!(plates.iter().all(Option::is_some), "every camera stands still");
        // The plate shows the wall where the dark thing stood for one step of six.
        let plate = plates[1].as_ref().expect("a plate");
        assert_eq!(plate.image.get_pixel(47, 35), &wall_color(camera(0.0).unproject_world(DVec2::new(47.0, 35.0), WALL_Z)));
        // A few seeds on the wall give the depth range.
        let mut seeds = PointCloud::default();
        for (x, y) in [(-0.5, -0.3), (0.4, 0.2), (0.1, -0.1), (-0.2, 0.35)] {
            seeds.positions_world.push([x, y, WALL_Z as f32]);
            seeds.colors.push(wall_color(DVec3::new(f64::from(x), f64::from(y), WALL_Z)).0);
        }
        let statics = plate_cloud(&cameras, &mut plates, &seeds, |t| Ok(frames[t].clone()), &options).expect("in memory").expect("plates");
        assert!(statics.points.len() > 1000, "a dense wall: {} points", statics.points.len());
        let on_wall = statics.points.positions_world.iter().filter(|p| (f64::from(p[2]) - WALL_Z).abs() < 0.01 * WALL_Z).count();
        assert!(on_wall * 100 >= statics.points.len() * 98, "{on_wall} of {} points on the wall", statics.points.len());
        assert!(statics.voxel_edge > 0.0);
        // The points behind the dark thing are lent at every step but the one where it stood.
        let behind: Vec<u32> = (0..statics.points.len() as u32)
            .filter(|&i| {
                let p = statics.points.positions_world[i as usize];
                DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])).distance(OCCLUDED) < 0.15
            })
            .collect();
        assert!(!behind.is_empty());
        for t in 0..STEPS {
            let lent = behind.iter().filter(|i| statics.active[t].contains(i)).count();
            if t == OCCLUDED_STEP {
                assert_eq!(lent, 0, "step {t}: nothing behind the dark thing is lent");
            } else {
                assert_eq!(lent, behind.len(), "step {t}: every point is lent");
            }
        }
    }

    #[test]
    fn a_point_that_more_cameras_contradict_than_see_is_dropped_with_the_contradiction_test() {
        // A wall with a plain red band: a point half way to it, painted red, lands on the band in
        // the two cameras at x = -0.4 and 0 (so both "see" it) and on the textured wall in the
        // three others, which look through it at another colour.
        const BAND: image::Rgb<u8> = image::Rgb([230, 20, 20]);
        let color_at = |p: DVec3| if (-0.05..0.45).contains(&p.x) { BAND } else { wall_color(p) };
        let cameras: Vec<Vec<Camera>> = [-0.8, -0.4, 0.0, 0.4, 0.8].into_iter().map(|x| vec![camera(x); 2]).collect();
        let frames: Vec<StepFrames> = (0..2)
            .map(|_| {
                cameras
                    .iter()
                    .map(|c| {
                        image::RgbImage::from_fn(96, 72, |u, v| {
                            color_at(c[0].unproject_world(DVec2::new(f64::from(u), f64::from(v)), WALL_Z))
                        })
                    })
                    .collect()
            })
            .collect();
        let plates = estimate_plates(&cameras, |t| Ok(frames[t].clone()), &PlateOptions::default()).expect("in memory");
        let floater = Vector3::new(0.0, 0.0, WALL_Z / 2.0);
        let mut positions = vec![floater];
        let mut colors = vec![BAND.0];
        for i in 0..200 {
            let (x, y) = (-0.6 + 1.2 * f64::from(i % 20) / 19.0, -0.4 + 0.8 * f64::from(i / 20) / 9.0);
            positions.push(Vector3::new(x, y, WALL_Z));
            colors.push(color_at(DVec3::new(x, y, WALL_Z)).0);
        }
        let on_wall = |kept: &Kept| kept.points.positions_world.iter().filter(|p| f64::from(p[2]) == WALL_Z).count();
        let floats = |kept: &Kept| kept.points.positions_world.iter().any(|p| f64::from(p[2]) < WALL_Z);
        let without = seen_points(&cameras, &plates, &positions, &colors, &PlateCloudOptions::default());
        assert!(floats(&without), "seen by two cameras, the point is kept without the test");
        let options = PlateCloudOptions { drop_contradicted: true, ..PlateCloudOptions::default() };
        let with = seen_points(&cameras, &plates, &positions, &colors, &options);
        assert!(!floats(&with), "three cameras contradict the point that two see");
        // Of the wall, only points within a pixel of the band's edges go (their plates mix the
        // two colours there, so cameras disagree on them).
        let pixel_m = WALL_Z / 80.0;
        for p in without.points.positions_world.iter().filter(|p| !with.points.positions_world.contains(p) && f64::from(p[2]) == WALL_Z) {
            let x = f64::from(p[0]);
            assert!((x + 0.05).abs() < pixel_m || (x - 0.45).abs() < pixel_m, "a wall point away from the band's edges dropped: {p:?}");
        }
        assert!(on_wall(&with) >= 190, "{} of 200 wall points kept", on_wall(&with));
    }

    #[test]
    fn cameras_that_move_get_no_plate_and_fewer_than_two_plates_give_no_cloud() {
        let (mut cameras, frames) = event();
        let moved = camera(0.1);
        cameras[0][STEPS - 1] = moved;
        cameras[1][STEPS - 1] = moved;
        assert!(!stands_still(&cameras[0]) && stands_still(&cameras[2]));
        let mut plates = estimate_plates(&cameras, |t| Ok(frames[t].clone()), &PlateOptions::default()).expect("in memory");
        assert_eq!(plates.iter().map(Option::is_some).collect::<Vec<_>>(), [false, false, true]);
        let seeds = PointCloud { positions_world: vec![[0.0, 0.0, 5.0]], colors: vec![[128; 3]] };
        let grown =
            plate_cloud(&cameras, &mut plates, &seeds, |t| Ok(frames[t].clone()), &PlateCloudOptions::default()).expect("in memory");
        assert!(grown.is_none());
    }
}
