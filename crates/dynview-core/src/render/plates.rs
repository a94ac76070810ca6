//! Background plates in the renderer (issue 33): where the novel pixel shows the static scene,
//! each view with a plate gives the plate's color rather than its frame's.
//!
//! A view that sees someone standing in front of the static scene, out of the novel view (beside
//! the virtual camera, or behind it), paints that person onto the static surface when its frame
//! is warped with the static surface's depth: no novel pixel carries the person's depth, so the
//! visibility test cannot know. The view's plate shows what that view sees behind the person.
//!
//! Which novel pixels show the static scene: the step's own points (the points it found itself,
//! moving things among them) and the static points it borrows are splatted separately into the
//! novel view, each over its footprint; a pixel where an own point lies nearer than the static
//! surface (by [`NEARER_MARGIN`]) shows something in front of it, and that region is grown by
//! `plate_moving_dilation_px`. Everywhere else is static. The mask's edge is feathered over
//! `plate_feather_px`, where a view mixes its frame's and its plate's colour ([`mixed`]). Where
//! the step has no static points, or no view a plate, nothing changes.

use super::params::RenderParams;
use super::sparse::nearest_depth;
use crate::camera::Camera;
use crate::points::PointCloud;
use crate::raster::{Raster, Rgb, ScalarRaster, box_filtered, dilated, min_filtered};

/// Relative depth by which an own point must lie nearer than the static surface to count as in
/// front of it.
pub const NEARER_MARGIN: f32 = 0.03;

/// Most pixels of a static mask: a novel view larger than this gets its mask at the largest
/// size of its aspect within it (the footprint, dilation and feather scaled alike), which the
/// renderer samples at the nearest pixel ([`mask_at`]) at every level. 960x540: the mask of a
/// 1080p or 4K view costs what a 540p view's does, and is as fine as the inputs of most
/// captures.
pub const STATIC_MASK_MAX_PIXELS: usize = 960 * 540;

/// The static mask of the novel view `camera` (1 where the pixel shows the static scene, 0
/// where something stands in front of it, in between over `plate_feather_px` of its edge), from
/// a cloud whose last `static_points` points are static; at the view's size, or smaller within
/// [`STATIC_MASK_MAX_PIXELS`]. `None` when there is no static point or the plates are off.
pub fn static_mask(params: &RenderParams, cloud: &PointCloud, static_points: usize, camera: &Camera) -> Option<ScalarRaster> {
    mask_of(params, cloud, static_points, &MaskGeometry::of(params, camera))
}

/// Where and how a static mask is computed: the camera it is seen by (the view's, or a smaller
/// one within [`STATIC_MASK_MAX_PIXELS`]) and the radii in that camera's pixels. The GPU's mask
/// (`dynview-gpu`) is computed on the same geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaskGeometry {
    /// The camera the mask is computed for.
    pub camera: Camera,
    /// Each point attached over this radius (`sparse_footprint_px`, scaled).
    pub footprint_px: usize,
    /// A pixel without a static point within the footprint takes the farthest static depth
    /// within this radius (`plate_static_reach_px`, scaled; at least `footprint_px`, where it
    /// changes nothing).
    pub static_reach_px: usize,
    /// The region in front grown by this radius (`plate_moving_dilation_px`, scaled).
    pub dilation_px: usize,
    /// The edge box-filtered over this radius (`plate_feather_px`, scaled).
    pub feather_px: usize,
}

impl MaskGeometry {
    /// The static mask's geometry for the novel view `camera`.
    pub fn of(params: &RenderParams, camera: &Camera) -> Self {
        let pixels = camera.width_px as usize * camera.height_px as usize;
        Self::at_scale(params, camera, (STATIC_MASK_MAX_PIXELS as f64 / pixels.max(1) as f64).sqrt().min(1.0))
    }

    /// At `scale` (at most 1) times `camera`'s size, radii scaled alike (at least 1 where not 0).
    fn at_scale(params: &RenderParams, camera: &Camera, scale: f64) -> Self {
        let camera = match scale < 1.0 {
            true => camera.resized(
                ((f64::from(camera.width_px) * scale).floor() as u32).max(1),
                ((f64::from(camera.height_px) * scale).floor() as u32).max(1),
            ),
            false => *camera,
        };
        let radius = |r: usize| if r == 0 { 0 } else { ((r as f64 * scale).round() as usize).max(1) };
        Self {
            camera,
            footprint_px: radius(params.sparse_footprint_px),
            static_reach_px: radius(params.plate_static_reach_px.max(params.sparse_footprint_px)),
            dilation_px: radius(params.plate_moving_dilation_px),
            feather_px: radius(params.plate_feather_px),
        }
    }
}

/// True when a cloud of `points` points, the last `static_points` static, has a static mask:
/// the plates on, and static points among its points (the CPU's and the GPU's test).
pub fn has_mask(params: &RenderParams, static_points: usize, points: usize) -> bool {
    params.plate_moving_dilation_px > 0 && static_points > 0 && static_points <= points
}

/// The static mask on `geometry`.
fn mask_of(params: &RenderParams, cloud: &PointCloud, static_points: usize, geometry: &MaskGeometry) -> Option<ScalarRaster> {
    if !has_mask(params, static_points, cloud.len()) {
        return None;
    }
    let MaskGeometry { camera, footprint_px, static_reach_px, dilation_px, feather_px } = *geometry;
    let split = cloud.len() - static_points;
    let own = attached_depth(&cloud.positions_world[..split], &camera, footprint_px);
    let mut statics = attached_depth(&cloud.positions_world[split..], &camera, footprint_px);
    if static_reach_px > footprint_px {
        statics = with_farthest_around(statics, static_reach_px);
    }
    let data = own
        .data
        .iter()
        .zip(&statics.data)
        .map(|(&own, &stat)| if own.is_finite() && own < stat * (1.0 - NEARER_MARGIN) { 1.0 } else { 0.0 })
        .collect();
    let nearer = Raster { width: own.width, height: own.height, data };
    let mut mask = dilated(&nearer, dilation_px);
    mask.data.iter_mut().for_each(|v| *v = 1.0 - *v);
    Some(if feather_px > 0 { box_filtered(&mask, feather_px) } else { mask })
}

/// The depth of the nearest of `positions_world` at each pixel of `camera`, each point attached
/// over `footprint_px` where a pixel has none of its own: the depth of
/// [`super::sparse::project_cloud`] then [`super::sparse::SplatMaps::with_footprint`], without
/// the colours.
fn attached_depth(positions_world: &[[f32; 3]], camera: &Camera, footprint_px: usize) -> ScalarRaster {
    let mut depth = nearest_depth(positions_world, camera);
    if footprint_px > 0 {
        let nearest_around = min_filtered(&depth, footprint_px);
        depth.data.iter_mut().zip(&nearest_around.data).filter(|(d, _)| !d.is_finite()).for_each(|(d, &n)| *d = n);
    }
    depth
}

/// `depth` where it has a depth, and elsewhere the farthest depth within `reach_px` (infinite
/// where there is none): the static surface an own point seen through a hole of the static
/// cloud is compared with. The farthest, not the nearest: behind a person standing in such a
/// hole the nearest static point around is often the floor in front of his feet, nearer than
/// he is, and the farthest the wall behind him.
fn with_farthest_around(mut depth: ScalarRaster, reach_px: usize) -> ScalarRaster {
    let finite = Raster {
        width: depth.width,
        height: depth.height,
        data: depth.data.iter().map(|&d| if d.is_finite() { d } else { 0.0 }).collect(),
    };
    let farthest = dilated(&finite, reach_px);
    depth
        .data
        .iter_mut()
        .zip(&farthest.data)
        .filter(|(d, _)| !d.is_finite())
        .for_each(|(d, &f)| *d = if f > 0.0 { f } else { f32::INFINITY });
    depth
}

/// A view's colour at a novel pixel whose static mask is `stat`: its frame's where nothing
/// static shows (0), its plate's where only the static scene does (1 and above), their mix in
/// between (a feathered edge).
#[inline]
pub fn mixed(frame: Rgb, plate: Rgb, stat: f32) -> Rgb {
    if stat >= 1.0 {
        plate
    } else if stat > 0.0 {
        std::array::from_fn(|k| frame[k] + (plate[k] - frame[k]) * stat)
    } else {
        frame
    }
}

/// `mask` at `width x height` by nearest sampling (the pixel whose area holds the sample's).
pub fn mask_at(mask: &ScalarRaster, width: usize, height: usize) -> ScalarRaster {
    if (mask.width, mask.height) == (width, height) {
        return mask.clone();
    }
    let data = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            mask.data[(y * mask.height / height) * mask.width + x * mask.width / width]
        })
        .collect();
    Raster { width, height, data }
}

#[cfg(test)]
mod tests {
    use super::super::sparse::project_cloud;
    use super::*;
    use crate::camera::{Intrinsics, Rigid3};

    fn camera() -> Camera {
        Camera {
            intrinsics: Intrinsics { fx: 40.0, fy: 40.0, cx: 19.5, cy: 14.5 },
            camera_from_world: Rigid3::IDENTITY,
            width_px: 40,
            height_px: 30,
        }
    }

    /// The world point that `camera()` sees at pixel `(x, y)` with z-depth `z`.
    fn at(x: f64, y: f64, z: f64) -> [f32; 3] {
        let p = camera().unproject_world(glam::DVec2::new(x, y), z);
        [p.x as f32, p.y as f32, p.z as f32]
    }

    /// A wall of static points at z = 10 over the whole view, and one own point at z = 5 in
    /// front of pixel (10, 10) plus one own point on the wall at pixel (30, 20).
    fn cloud() -> (PointCloud, usize) {
        let mut cloud = PointCloud::default();
        cloud.positions_world.push(at(10.0, 10.0, 5.0));
        cloud.positions_world.push(at(30.0, 20.0, 10.0));
        let mut statics = 0;
        for y in 0..30 {
            for x in 0..40 {
                cloud.positions_world.push(at(f64::from(x), f64::from(y), 10.0));
                statics += 1;
            }
        }
        cloud.colors = vec![[128; 3]; cloud.positions_world.len()];
        (cloud, statics)
    }

    #[test]
    fn pixels_near_an_own_point_in_front_of_the_static_scene_are_not_static() {
        let (cloud, statics) = cloud();
        let params = RenderParams { plate_moving_dilation_px: 3, sparse_footprint_px: 1, plate_feather_px: 0, ..RenderParams::default() };
        let mask = static_mask(&params, &cloud, statics, &camera()).expect("static points and plates on");
        let at = |x: usize, y: usize| mask.data[y * 40 + x];
        // The point in front, its footprint (1) and the dilation (3): 4 pixels each way.
        assert_eq!(at(10, 10), 0.0);
        assert_eq!(at(14, 10), 0.0);
        assert_eq!(at(10, 6), 0.0);
        assert_eq!(at(15, 10), 1.0);
        assert_eq!(at(10, 15), 1.0);
        // An own point on the static surface itself leaves its pixels static.
        assert_eq!(at(30, 20), 1.0);
        assert_eq!(mask.data.iter().filter(|&&v| v == 0.0).count(), 81, "a 9x9 square");
    }

    #[test]
    fn an_own_point_in_a_hole_of_the_static_cloud_is_compared_with_the_surface_around_it() {
        // The wall of `cloud` with a hole of 9x9 pixels around (30, 20), where the own point on
        // the wall lies, and a second own point 30% in front of the wall inside the hole.
        let cam = camera();
        let (mut cloud, _) = cloud();
        let hole = |p: &[f32; 3]| {
            let pixel = cam.project_world(glam::DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])));
            pixel.is_some_and(|(q, _)| (q.x - 30.0).abs() <= 4.5 && (q.y - 20.0).abs() <= 4.5 && p[2] > 9.0)
        };
        let own = [cloud.positions_world[0], cloud.positions_world[1], at(26.0, 16.0, 7.0)];
        let statics: Vec<[f32; 3]> = cloud.positions_world[2..].iter().copied().filter(|p| !hole(p)).collect();
        cloud.positions_world = own.iter().chain(&statics).copied().collect();
        cloud.colors = vec![[128; 3]; cloud.positions_world.len()];
        let mask_with = |reach: usize| {
            let params = RenderParams {
                plate_moving_dilation_px: 1,
                sparse_footprint_px: 1,
                plate_feather_px: 0,
                plate_static_reach_px: reach,
                ..RenderParams::default()
            };
            static_mask(&params, &cloud, statics.len(), &cam).expect("static points and plates on")
        };
        let (near, far) = (mask_with(0), mask_with(6));
        let at_mask = |mask: &ScalarRaster, x: usize, y: usize| mask.data[y * 40 + x];
        assert_eq!(at_mask(&near, 30, 20), 0.0, "with the footprint alone the wall's own point finds no static point");
        assert_eq!(at_mask(&far, 30, 20), 1.0, "within the reach it finds the wall around it and stays static");
        assert_eq!(at_mask(&far, 26, 16), 0.0, "the own point in front of the wall stays in front");
        assert_eq!(at_mask(&far, 10, 10), 0.0, "and so does the one in front outside the hole");
        assert_eq!(mask_with(1).data, near.data, "a reach within the footprint changes nothing");
    }

    #[test]
    fn an_own_point_in_a_hole_is_compared_with_the_farthest_static_surface_around_it() {
        // The wall of `cloud` with a hole of 9x9 pixels around (30, 20), a patch of floor 6 m
        // away just left of the hole (x 24-25, y 18-22, in front of the wall), and an own point
        // 8 m away in the hole (a person's leg between the floor in front and the wall behind).
        let cam = camera();
        let in_hole = |x: f64, y: f64| (x - 30.0).abs() <= 4.5 && (y - 20.0).abs() <= 4.5;
        let mut statics: Vec<[f32; 3]> = Vec::new();
        for y in 0..30 {
            for x in 0..40 {
                let (x, y) = (f64::from(x), f64::from(y));
                if (24.0..=25.0).contains(&x) && (18.0..=22.0).contains(&y) {
                    statics.push(at(x, y, 6.0));
                } else if !in_hole(x, y) {
                    statics.push(at(x, y, 10.0));
                }
            }
        }
        let mut cloud = PointCloud::default();
        cloud.positions_world = std::iter::once(at(28.0, 20.0, 8.0)).chain(statics.iter().copied()).collect();
        cloud.colors = vec![[128; 3]; cloud.positions_world.len()];
        let params = RenderParams {
            plate_moving_dilation_px: 1,
            sparse_footprint_px: 1,
            plate_feather_px: 0,
            plate_static_reach_px: 6,
            ..RenderParams::default()
        };
        let mask = static_mask(&params, &cloud, statics.len(), &cam).expect("static points and plates on");
        // The nearest static point around (the floor, 6 m) is nearer than the leg; the farthest
        // (the wall, 10 m) is behind it.
        assert_eq!(mask.data[20 * 40 + 28], 0.0, "the leg stands in front of the wall behind it");
    }

    #[test]
    fn attached_depth_is_the_depth_of_the_splat_with_its_footprint() {
        let cam = camera();
        let mut state = 7u32;
        let mut next = || {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12345);
            f64::from(state >> 16) / 65536.0
        };
        let mut cloud = PointCloud::default();
        for _ in 0..300 {
            // Some points off the image and some behind the camera.
            let (x, y, z) = (next() * 50.0 - 5.0, next() * 40.0 - 5.0, next() * 12.0 - 1.0);
            let p = cam.unproject_world(glam::DVec2::new(x, y), z.max(0.5));
            let z_sign = if z < 0.0 { -1.0 } else { 1.0 };
            cloud.positions_world.push([p.x as f32, p.y as f32, (p.z * z_sign) as f32]);
        }
        cloud.colors = vec![[9; 3]; cloud.positions_world.len()];
        for radius in [0, 1, 2, 3] {
            let expected = project_cloud(&cloud, &cam).with_footprint(radius).depth.data;
            assert_eq!(attached_depth(&cloud.positions_world, &cam, radius).data, expected, "radius {radius}");
        }
    }

    #[test]
    fn a_feathered_mask_rises_across_the_edge_and_mixes_frame_and_plate() {
        let (cloud, statics) = cloud();
        let hard = RenderParams { plate_moving_dilation_px: 3, sparse_footprint_px: 1, plate_feather_px: 0, ..RenderParams::default() };
        let soft = RenderParams { plate_feather_px: 2, ..hard.clone() };
        let (hard, soft) =
            (static_mask(&hard, &cloud, statics, &camera()).unwrap(), static_mask(&soft, &cloud, statics, &camera()).unwrap());
        // Along row 10 the hard edge runs from 0 (x <= 14) to 1 (x >= 15); feathered over 2 px
        // the mask rises through it, and is the hard one away from it.
        let row: Vec<f32> = (10..=20).map(|x| soft.data[10 * 40 + x]).collect();
        assert!(row.windows(2).all(|w| w[1] >= w[0]), "{row:?}");
        assert_eq!(soft.data[10 * 40 + 10], 0.0);
        assert_eq!(soft.data[10 * 40 + 20], 1.0);
        assert!(soft.data[10 * 40 + 14] > 0.0 && soft.data[10 * 40 + 15] < 1.0, "{row:?}");
        let edge = soft.data.iter().zip(&hard.data).filter(|(s, h)| s != h).count();
        assert!(edge > 0 && soft.data.iter().all(|v| (0.0..=1.0).contains(v)));
        // Frame and plate mixed by the mask's value.
        assert_eq!(mixed([0.0, 0.2, 1.0], [1.0, 0.2, 0.0], 0.0), [0.0, 0.2, 1.0]);
        assert_eq!(mixed([0.0, 0.2, 1.0], [1.0, 0.2, 0.0], 1.0), [1.0, 0.2, 0.0]);
        assert_eq!(mixed([0.0, 0.2, 1.0], [1.0, 0.2, 0.0], 0.25), [0.25, 0.2, 0.75]);
    }

    #[test]
    fn a_large_view_gets_its_mask_at_most_at_the_largest_size_and_alike() {
        // The wall, the point in front of it and a block of points in front, seen by a view
        // 32 times as large as `camera()` (1280x960).
        let (mut cloud, statics) = cloud();
        let cam = camera();
        let block: Vec<[f32; 3]> = (0..16)
            .map(|i| {
                let p = cam.unproject_world(glam::DVec2::new(20.0 + f64::from(i % 4), 5.0 + f64::from(i / 4)), 5.0);
                [p.x as f32, p.y as f32, p.z as f32]
            })
            .collect();
        cloud.positions_world.splice(0..0, block);
        cloud.colors = vec![[128; 3]; cloud.positions_world.len()];
        let params = RenderParams { plate_moving_dilation_px: 64, sparse_footprint_px: 32, plate_feather_px: 6, ..RenderParams::default() };
        assert_eq!(static_mask(&params, &cloud, statics, &cam).map(|m| (m.width, m.height)), Some((40, 30)), "a small view's mask");
        let large = cam.resized(1280, 960);
        let capped = static_mask(&params, &cloud, statics, &large).unwrap();
        assert!(capped.width * capped.height <= STATIC_MASK_MAX_PIXELS);
        let aspect = capped.width as f64 / capped.height as f64;
        assert!((aspect - 4.0 / 3.0).abs() < 0.01, "aspect {aspect} of {}x{}", capped.width, capped.height);
        // Sampled at the view's size it is the mask computed there, but on the edges.
        let full = mask_of(&params, &cloud, statics, &MaskGeometry::at_scale(&params, &large, 1.0)).unwrap();
        let sampled = mask_at(&capped, 1280, 960);
        let differing = sampled.data.iter().zip(&full.data).filter(|(a, b)| (**a - **b).abs() > 0.25).count();
        let masked = full.data.iter().filter(|&&v| v < 0.5).count();
        assert!(masked > 100_000, "{masked} pixels in front");
        assert!(differing * 100 < masked * 2, "{differing} pixels differ, {masked} in front");
    }

    #[test]
    fn no_static_points_or_plates_off_means_no_mask() {
        let (cloud, statics) = cloud();
        assert!(static_mask(&RenderParams::default(), &cloud, 0, &camera()).is_none());
        let off = RenderParams { plate_moving_dilation_px: 0, ..RenderParams::default() };
        assert!(static_mask(&off, &cloud, statics, &camera()).is_none());
        assert!(static_mask(&RenderParams::default(), &cloud, cloud.len() + 1, &camera()).is_none());
    }

    #[test]
    fn masks_are_sampled_at_each_level() {
        let mask = Raster { width: 4, height: 2, data: vec![1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0] };
        let half = mask_at(&mask, 2, 1);
        assert_eq!(half.data, vec![1.0, 1.0]);
        assert_eq!(mask_at(&mask, 4, 2).data, mask.data);
    }
}
