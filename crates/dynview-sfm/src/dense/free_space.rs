//! Own points that float in free space (issue 33): a point of a step's own cloud cannot stand in
//! front of the static scene where a still camera looking through it sees its background plate
//! (nothing moved in there). Stereo on single frames leaves such points (a reflective floor,
//! a plain wall); the renderer's consistency filter cannot tell them from a sparse object in
//! front of the dense static cloud, so prep drops them where the plates say so.
//!
//! A point *floats* when at least [`FreeSpaceOptions::min_votes`] cameras with a plate, and more
//! than call its pixel foreground, see it more than [`FreeSpaceOptions::margin`] (a share of the
//! depth) in front of the static scene at a pixel their foreground (grown, as the hull carves:
//! [`super::hull::Foreground::keeps`]) calls background. A pixel the soft foreground is unsure
//! of (neither in [`super::hull::Foreground::grown`] nor carving) votes neither way.

use dynview_core::Camera;
use dynview_core::raster::ScalarRaster;
use dynview_core::render::sparse::project_cloud;
use dynview_core::scene::PointCloud;
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::hull::Foreground;
use crate::error::{SfmError, SfmResult};

/// When an own point counts as floating.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FreeSpaceOptions {
    /// How far in front of the static scene a point must be, as a share of the static depth,
    /// for a camera that sees the plate there to vote against it.
    pub margin: f64,
    /// Fewest cameras that must vote against a point.
    pub min_votes: usize,
    /// Radius (px) over which each static point covers the static depth map (the nearest wins).
    pub footprint_px: usize,
}

impl Default for FreeSpaceOptions {
    fn default() -> Self {
        Self { margin: 0.05, min_votes: 2, footprint_px: 2 }
    }
}

impl FreeSpaceOptions {
    /// Checks the ranges.
    pub fn validate(&self) -> SfmResult<()> {
        let bad = |problem: &str| Err(SfmError::Option { option: "free_space", problem: problem.to_string() });
        if !(self.margin.is_finite() && self.margin > 0.0 && self.margin < 1.0) {
            return bad("margin must lie in (0, 1)");
        }
        if self.min_votes == 0 {
            return bad("min_votes must be at least 1");
        }
        if self.footprint_px > 16 {
            return bad("footprint_px must be at most 16");
        }
        Ok(())
    }
}

/// The depth (m) of the static scene in `camera`: `static_points` z-buffered, each over
/// `footprint_px` pixels; infinity where none lands.
pub fn static_depth_map(camera: &Camera, static_points: &PointCloud, footprint_px: usize) -> ScalarRaster {
    project_cloud(static_points, camera).with_footprint(footprint_px).depth
}

/// One still camera at a step, as the free-space test reads it.
#[derive(Clone, Copy, Debug)]
pub struct FreeSpaceView<'a> {
    /// The camera (its working size: the foreground's and the depth map's).
    pub camera: &'a Camera,
    /// Its foreground at the step.
    pub foreground: &'a Foreground,
    /// Its static depth map ([`static_depth_map`]).
    pub static_depth_m: &'a ScalarRaster,
}

/// The points of `own` that do not float in front of the static scene of `views`, and how many
/// were dropped.
pub fn drop_floaters(own: &PointCloud, views: &[FreeSpaceView], options: &FreeSpaceOptions) -> (PointCloud, usize) {
    let keep: Vec<usize> = (0..own.len()).filter(|&i| !floats(own.positions_world[i], views, options)).collect();
    let dropped = own.len() - keep.len();
    (own.select(keep), dropped)
}

/// Whether the point `p` floats (see the module's documentation).
fn floats(p: [f32; 3], views: &[FreeSpaceView], options: &FreeSpaceOptions) -> bool {
    let world = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
    let (mut against, mut foreground) = (0, 0);
    for view in views {
        let Some((pixel, z)) = view.camera.project_world(world) else { continue };
        let (x, y) = (pixel.x.round(), pixel.y.round());
        let (w, h) = (view.static_depth_m.width, view.static_depth_m.height);
        if !(z > 0.0 && x >= 0.0 && y >= 0.0 && (x as usize) < w && (y as usize) < h) {
            continue;
        }
        let i = y as usize * w + x as usize;
        if view.foreground.grown.data.get(i).is_some_and(|&k| k > 0.0) {
            foreground += 1;
            continue;
        }
        if view.foreground.keeps.data.get(i).is_some_and(|&k| k > 0.0) {
            // Unsure (the soft foreground): this camera says nothing.
            continue;
        }
        let behind = f64::from(view.static_depth_m.data[i]);
        if behind.is_finite() && z < behind * (1.0 - options.margin) {
            against += 1;
        }
    }
    against >= options.min_votes && against > foreground
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_core::{Intrinsics, Rigid3};
    use glam::DMat3;

    const W: u32 = 40;
    const H: u32 = 30;

    fn camera(x_m: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics { fx: 40.0, fy: 40.0, cx: 19.5, cy: 14.5 },
            camera_from_world: Rigid3::new(DMat3::IDENTITY, DVec3::new(-x_m, 0.0, 0.0)),
            width_px: W,
            height_px: H,
        }
    }

    /// A wall at z = 5 m, a point every 5 cm.
    fn wall() -> PointCloud {
        let mut cloud = PointCloud::default();
        for i in -40..=40 {
            for j in -30..=30 {
                cloud.positions_world.push([i as f32 * 0.05, j as f32 * 0.05, 5.0]);
                cloud.colors.push([128; 3]);
            }
        }
        cloud
    }

    /// A foreground that is 1 inside the square `[x0, x1) x [y0, y1)` of pixels, 0 elsewhere.
    fn foreground(square: Option<(usize, usize, usize, usize)>) -> Foreground {
        let mut keeps = ScalarRaster::filled(W as usize, H as usize, 0.0);
        if let Some((x0, x1, y0, y1)) = square {
            for y in y0..y1 {
                for x in x0..x1 {
                    keeps.data[y * W as usize + x] = 1.0;
                }
            }
        }
        Foreground {
            probability: keeps.clone(),
            mask: keeps.clone(),
            unknown: ScalarRaster::filled(W as usize, H as usize, 0.0),
            grown: keeps.clone(),
            keeps,
        }
    }

    #[test]
    fn a_point_in_front_of_the_wall_where_the_cameras_see_the_wall_floats_and_one_they_see_stays() {
        let cameras = [camera(-0.5), camera(0.0), camera(0.5)];
        let depths: Vec<ScalarRaster> = cameras.iter().map(|c| static_depth_map(c, &wall(), 2)).collect();
        let options = FreeSpaceOptions::default();
        // Two points 2 m in front of the wall: each camera's foreground covers the second one
        // (something moved in there), none covers the first.
        let floater = [0.0, 0.0, 3.0];
        let seen = [0.2, 0.1, 3.0];
        let on_wall = [0.3, -0.2, 5.0];
        let own = PointCloud { positions_world: vec![floater, seen, on_wall], colors: vec![[0; 3]; 3] };
        let foregrounds: Vec<Foreground> = cameras
            .iter()
            .map(|c| {
                let (pixel, _) = c.project_world(DVec3::new(0.2, 0.1, 3.0)).unwrap();
                let (x, y) = (pixel.x.round() as usize, pixel.y.round() as usize);
                foreground(Some((x - 1, x + 2, y - 1, y + 2)))
            })
            .collect();
        let views: Vec<FreeSpaceView> =
            (0..3).map(|c| FreeSpaceView { camera: &cameras[c], foreground: &foregrounds[c], static_depth_m: &depths[c] }).collect();
        let (kept, dropped) = drop_floaters(&own, &views, &options);
        assert_eq!(dropped, 1);
        assert_eq!(kept.positions_world, vec![seen, on_wall], "the floater goes; the point the cameras see and the wall's stay");
        // One camera's vote is not enough.
        let (_, dropped) = drop_floaters(&own, &views[..1], &options);
        assert_eq!(dropped, 0);
    }

    #[test]
    fn a_camera_unsure_of_its_foreground_votes_neither_way() {
        let cameras = [camera(-0.5), camera(0.0), camera(0.5), camera(1.0)];
        let depths: Vec<ScalarRaster> = cameras.iter().map(|c| static_depth_map(c, &wall(), 2)).collect();
        let floater = [0.0, 0.0, 3.0];
        let own = PointCloud { positions_world: vec![floater], colors: vec![[0; 3]] };
        // Two cameras see the plate behind the point; the other two see something there, surely
        // or (the soft foreground) unsurely: they keep their pixel from carving but are not in
        // its grown mask.
        let dropped_when = |sure: bool| {
            let foregrounds: Vec<Foreground> = cameras
                .iter()
                .enumerate()
                .map(|(c, camera)| {
                    if c < 2 {
                        return foreground(None);
                    }
                    let (pixel, _) = camera.project_world(DVec3::from_array(floater.map(f64::from))).unwrap();
                    let (x, y) = (pixel.x.round() as usize, pixel.y.round() as usize);
                    let mut f = foreground(Some((x - 1, x + 2, y - 1, y + 2)));
                    if !sure {
                        f.grown = ScalarRaster::filled(W as usize, H as usize, 0.0);
                    }
                    f
                })
                .collect();
            let views: Vec<FreeSpaceView> =
                (0..4).map(|c| FreeSpaceView { camera: &cameras[c], foreground: &foregrounds[c], static_depth_m: &depths[c] }).collect();
            drop_floaters(&own, &views, &FreeSpaceOptions::default()).1
        };
        assert_eq!(dropped_when(true), 0, "two against, two for: it stays");
        assert_eq!(dropped_when(false), 1, "two against, two unsure: it goes");
    }

    #[test]
    fn options_out_of_range_are_refused() {
        for bad in [FreeSpaceOptions { margin: 0.0, ..Default::default() }, FreeSpaceOptions { min_votes: 0, ..Default::default() }] {
            assert!(bad.validate().is_err());
        }
        FreeSpaceOptions::default().validate().unwrap();
    }
}
