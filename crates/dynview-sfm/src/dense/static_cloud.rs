//! Static surfaces accumulated across time (issue 15). The paper never matches points through
//! time, but the static part of a scene is the same at every time step, and each step finds
//! its points on different parts of it. Candidates are the points of some of the steps; a
//! candidate is static when, in the cameras that saw it at its own step, the frames show the
//! same color where it projects at (nearly) every other step. The static points, one per voxel,
//! are then lent to every step where they agree with that step's frames: a borrowed point that
//! disagrees at `t` (something moved in front of it, in most of its cameras) is left out at `t`.
//!
//! Colors are compared within one camera across time (never across cameras), so exposure and
//! white balance that differ between cameras do not matter; a camera may move (its pose per
//! step is used).

use std::collections::{HashMap, HashSet};

use dynview_core::Camera;
use dynview_core::scene::PointCloud;
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How the static cloud is built.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StaticOptions {
    /// Steps whose points are candidates, at most (spread evenly over the event).
    pub candidate_steps: usize,
    /// Mean absolute RGB difference (colors in `[0, 1]`) below which two samples of one camera
    /// agree.
    pub color_tolerance: f32,
    /// Largest mean absolute RGB difference between a candidate's color and a camera's frame at
    /// its own step for that camera to count as seeing it.
    pub seen_tolerance: f32,
    /// Share of (step, camera) samples that must agree for a candidate to be static.
    pub min_static_share: f32,
    /// Voxel edge in pixels of the first camera at the static points' median depth: the static
    /// candidates of one voxel become one point (their mean position).
    pub voxel_px: f64,
    /// Candidate steps that must have found a static candidate in a voxel for it to count: a
    /// surface found again and again is where it seems, a stray point of one step is not.
    pub min_support_steps: usize,
}

impl Default for StaticOptions {
    fn default() -> Self {
        Self {
            candidate_steps: 12,
            color_tolerance: 0.06,
            seen_tolerance: 0.15,
            min_static_share: 0.8,
            voxel_px: 2.0,
            min_support_steps: 3,
        }
    }
}

/// A static cloud and, per step, which of its points agree with the step's frames.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StaticCloud {
    /// The static points, one per voxel.
    pub points: PointCloud,
    /// Per step, the indices of the static points that agree with its frames.
    pub active: Vec<Vec<u32>>,
    /// Candidates examined.
    pub candidates: usize,
    /// Edge of the voxels the static points stand for (world units; 0 without static points).
    pub voxel_edge: f64,
    /// Plate pixels repaired on the way, over all cameras (a cloud from plates only;
    /// [`super::plate_repair`]).
    pub repaired_plate_pixels: usize,
}

impl StaticCloud {
    /// The points lent to step `t`: the static points active there. Where the step found a
    /// point of its own in a static point's voxel, both are kept (the static one is the mean
    /// of several steps' points, so a z-test between them changes nothing that matters).
    pub fn borrowed(&self, t: usize) -> PointCloud {
        self.points.select(self.active.get(t).into_iter().flatten().map(|&i| i as usize))
    }

    /// The points of `own` (step `t`'s) neither in nor next to (the 26 neighbours) a voxel whose
    /// static point is active at `t`: the step needs only these beside the static points it
    /// borrows, which sample the surface there every voxel (2 px) already. A format v2 package
    /// stores only these per step.
    pub fn own_not_covered(&self, t: usize, own: &PointCloud) -> PointCloud {
        if self.voxel_edge <= 0.0 {
            return own.clone();
        }
        let voxel = |p: [f32; 3]| (to_dvec3(p) / self.voxel_edge).floor().as_ivec3();
        let covered: HashSet<glam::IVec3> =
            self.active.get(t).into_iter().flatten().map(|&i| voxel(self.points.positions_world[i as usize])).collect();
        let near =
            |v: glam::IVec3| (-1..=1).any(|x| (-1..=1).any(|y| (-1..=1).any(|z| covered.contains(&(v + glam::IVec3::new(x, y, z))))));
        own.select((0..own.len()).filter(|&i| !near(voxel(own.positions_world[i]))))
    }
}

/// The steps whose points are candidates: at most `n`, spread evenly over `steps`.
pub fn candidate_steps(steps: usize, n: usize) -> Vec<usize> {
    if steps == 0 || n == 0 {
        return Vec::new();
    }
    let n = n.min(steps);
    (0..n).map(|k| (k * steps + steps / 2) / n).collect()
}

/// Bilinear sample of `image` at `pixel` (pixel centres at integers), in `[0, 1]`; `None`
/// outside the image.
pub(super) fn sample(image: &image::RgbImage, x: f64, y: f64) -> Option<[f32; 3]> {
    let (w, h) = (f64::from(image.width()), f64::from(image.height()));
    if !(x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0) {
        return None;
    }
    let (x0, y0) = (x.floor() as u32, y.floor() as u32);
    let (x1, y1) = ((x0 + 1).min(image.width() - 1), (y0 + 1).min(image.height() - 1));
    let (fx, fy) = ((x - f64::from(x0)) as f32, (y - f64::from(y0)) as f32);
    let (a, b, c, d) = (image.get_pixel(x0, y0), image.get_pixel(x1, y0), image.get_pixel(x0, y1), image.get_pixel(x1, y1));
    let mut out = [0.0; 3];
    for k in 0..3 {
        let top = f32::from(a[k]) + (f32::from(b[k]) - f32::from(a[k])) * fx;
        let bottom = f32::from(c[k]) + (f32::from(d[k]) - f32::from(c[k])) * fx;
        out[k] = (top + (bottom - top) * fy) / 255.0;
    }
    Some(out)
}

pub(super) fn difference(a: [f32; 3], b: [f32; 3]) -> f32 {
    ((a[0] - b[0]).abs() + (a[1] - b[1]).abs() + (a[2] - b[2]).abs()) / 3.0
}

/// Frames of one step, one per camera (working size), as the static cloud reads them.
pub type StepFrames = Vec<image::RgbImage>;

/// Steps whose frames judge whether a candidate is static, at most (spread evenly): enough to
/// see a passing object, few enough to keep memory and time small on long events.
pub const JUDGING_STEPS: usize = 48;

/// Per candidate and camera: the color it showed at the candidate's own step, when the camera
/// saw it there.
type OwnColors = Vec<Option<[f32; 3]>>;

/// How many of the cameras that saw candidate `i` (`own[i * cameras + c]`) show its color at step
/// `t` (frames `frames`, cameras `at_t`).
pub(super) fn agreeing_cameras(
    point: DVec3,
    own: &[Option<[f32; 3]>],
    at_t: &[Camera],
    frames: &[image::RgbImage],
    tolerance: f32,
) -> usize {
    own.iter()
        .zip(at_t.iter().zip(frames))
        .filter(|(own, (camera, frame))| {
            own.is_some_and(|own| {
                camera
                    .project_world(point)
                    .and_then(|(pixel, _)| sample(frame, pixel.x, pixel.y))
                    .is_some_and(|c| difference(c, own) <= tolerance)
            })
        })
        .count()
}

/// Builds the static cloud of an event from the clouds of its `candidate` steps
/// (`(step, cloud)`). `cameras[c][t]` is camera `c` at step `t`; `frames_at(t)` reads the frames
/// of step `t` (one per camera). Frames are read one step at a time (a few steps at once when
/// running in parallel), so memory does not grow with the event's length.
pub fn build_static_cloud<E: Send>(
    cameras: &[Vec<Camera>],
    frames_at: impl Fn(usize) -> Result<StepFrames, E> + Sync,
    candidates: &[(usize, PointCloud)],
    options: &StaticOptions,
) -> Result<StaticCloud, E> {
    let steps = cameras.first().map_or(0, Vec::len);
    let count = cameras.len();
    let at_step = |t: usize| -> Vec<Camera> { cameras.iter().map(|c| c[t]).collect() };
    let mut all = PointCloud::default();
    let mut origin = Vec::new();
    for (t, cloud) in candidates {
        all.positions_world.extend_from_slice(&cloud.positions_world);
        all.colors.extend_from_slice(&cloud.colors);
        origin.extend(std::iter::repeat_n(*t, cloud.len()));
    }
    let n = all.len();
    if n == 0 {
        return Ok(StaticCloud { active: vec![Vec::new(); steps], ..StaticCloud::default() });
    }
    // Which cameras saw each candidate at its own step, and the color they showed.
    let mut own: OwnColors = vec![None; n * count];
    for (s, _) in candidates {
        let frames = frames_at(*s)?;
        let at_s = at_step(*s);
        for i in (0..n).filter(|&i| origin[i] == *s) {
            let color = all.colors[i].map(|v| f32::from(v) / 255.0);
            for (c, (camera, frame)) in at_s.iter().zip(&frames).enumerate() {
                let shown = camera.project_world(point(&all, i)).and_then(|(pixel, _)| sample(frame, pixel.x, pixel.y));
                own[i * count + c] = shown.filter(|&shown| difference(shown, color) <= options.seen_tolerance);
            }
        }
    }
    let seen: Vec<usize> = (0..n).map(|i| own[i * count..(i + 1) * count].iter().filter(|o| o.is_some()).count()).collect();
    // Static: the colors stay in at least min_static_share of the judging steps' samples.
    let judging = candidate_steps(steps, JUDGING_STEPS);
    let judged: Vec<Vec<u8>> = judging
        .par_iter()
        .map(|&t| {
            let frames = frames_at(t)?;
            let at_t = at_step(t);
            Ok((0..n)
                .map(|i| agreeing_cameras(point(&all, i), &own[i * count..(i + 1) * count], &at_t, &frames, options.color_tolerance) as u8)
                .collect())
        })
        .collect::<Result<_, E>>()?;
    let mut statics = Vec::new();
    for index in (0..n).filter(|&i| seen[i] >= 2) {
        let agreeing: usize = judged.iter().map(|a| usize::from(a[index])).sum();
        let share = agreeing as f32 / (seen[index] * judging.len()).max(1) as f32;
        if share >= options.min_static_share {
            statics.push(Static { index, share });
        }
    }
    // One point per supported voxel: its candidates' mean position, the most static one's color
    // and cameras.
    let mut out = StaticCloud { candidates: n, active: vec![Vec::new(); steps], ..StaticCloud::default() };
    let mut representative = Vec::new();
    let (groups, edge) = voxels(cameras, &all, &statics, options.voxel_px);
    out.voxel_edge = edge;
    for voxel in groups {
        let support: HashSet<usize> = voxel.iter().map(|&k| origin[statics[k].index]).collect();
        if support.len() < options.min_support_steps {
            continue;
        }
        let mean = voxel.iter().map(|&k| point(&all, statics[k].index)).sum::<DVec3>() / voxel.len() as f64;
        let Some(&best) = voxel.iter().max_by(|&&a, &&b| statics[a].share.total_cmp(&statics[b].share)) else { continue };
        let best = statics[best].index;
        out.points.positions_world.push([mean.x as f32, mean.y as f32, mean.z as f32]);
        out.points.colors.push(all.colors[best]);
        representative.push(best);
    }
    if representative.is_empty() {
        return Ok(out);
    }
    // Lent at t where most of the cameras that saw it, and at least two, still agree.
    out.active = (0..steps)
        .into_par_iter()
        .map(|t| {
            let frames = frames_at(t)?;
            let at_t = at_step(t);
            Ok(representative
                .iter()
                .enumerate()
                .filter(|&(k, &i)| {
                    let agree = agreeing_cameras(
                        to_dvec3(out.points.positions_world[k]),
                        &own[i * count..(i + 1) * count],
                        &at_t,
                        &frames,
                        options.color_tolerance,
                    );
                    agree >= 2 && 3 * agree >= 2 * seen[i]
                })
                .map(|(k, _)| k as u32)
                .collect())
        })
        .collect::<Result<_, E>>()?;
    Ok(out)
}

/// A static candidate: its index and its share of agreeing samples.
struct Static {
    index: usize,
    share: f32,
}

fn to_dvec3(p: [f32; 3]) -> DVec3 {
    DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
}

fn point(cloud: &PointCloud, i: usize) -> DVec3 {
    to_dvec3(cloud.positions_world[i])
}

/// The static candidates grouped by voxel (indices into `statics`, groups in the order of
/// their first candidate) and the voxel edge: `voxel_px` pixels of the first camera's first
/// view at the candidates' median depth.
fn voxels(cameras: &[Vec<Camera>], all: &PointCloud, statics: &[Static], voxel_px: f64) -> (Vec<Vec<usize>>, f64) {
    let Some(camera) = cameras.first().and_then(|c| c.first()) else {
        return (Vec::new(), 0.0);
    };
    let mut depths: Vec<f64> = statics.iter().map(|s| camera.camera_from_world.transform_point(point(all, s.index)).z.abs()).collect();
    depths.sort_by(f64::total_cmp);
    let median = depths.get(depths.len() / 2).copied().unwrap_or(1.0);
    let edge = (median * voxel_px / camera.intrinsics.fx.max(1e-9)).max(1e-9);
    let mut groups: HashMap<glam::IVec3, Vec<usize>> = HashMap::new();
    for (k, s) in statics.iter().enumerate() {
        groups.entry((point(all, s.index) / edge).floor().as_ivec3()).or_default().push(k);
    }
    let mut out: Vec<Vec<usize>> = groups.into_values().collect();
    out.sort_by_key(|g| g[0]);
    (out, edge)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_core::{Intrinsics, Rigid3};
    use glam::{DMat3, DVec2};

    const STEPS: usize = 6;
    const OCCLUDED_STEP: usize = 3;
    /// A static point on the wall that something dark passes in front of at [`OCCLUDED_STEP`].
    const WALL_POINT: [f32; 3] = [0.0, 0.0, 5.0];
    /// A point on a red thing that is only there at step 0.
    const PASSING_POINT: [f32; 3] = [0.1, 0.4, 3.0];

    fn camera(x_m: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics { fx: 50.0, fy: 50.0, cx: 31.5, cy: 23.5 },
            camera_from_world: Rigid3::new(DMat3::IDENTITY, DVec3::new(-x_m, 0.0, 0.0)),
            width_px: 64,
            height_px: 48,
        }
    }

    /// The wall's color at a world point of the plane z = 5.
    fn wall_color(p: DVec3) -> [u8; 3] {
        let f = |v: f64| (255.0 * v).round() as u8;
        [f(0.5 + 0.4 * (3.0 * p.x).sin()), f(0.5 + 0.4 * (2.0 * p.y).cos()), 128]
    }

    fn near(camera: &Camera, point: [f32; 3], pixel: DVec2, radius_px: f64) -> bool {
        let p = DVec3::new(f64::from(point[0]), f64::from(point[1]), f64::from(point[2]));
        camera.project_world(p).is_some_and(|(q, _)| q.distance(pixel) <= radius_px)
    }

    /// The cameras (`[camera][step]`) and frames (`[step][camera]`) of the test event.
    fn event() -> (Vec<Vec<Camera>>, Vec<StepFrames>) {
        let cameras: Vec<Camera> = [-0.5, 0.0, 0.5].into_iter().map(camera).collect();
        let frames = (0..STEPS)
            .map(|t| {
                cameras
                    .iter()
                    .map(|camera| {
                        image::RgbImage::from_fn(64, 48, |u, v| {
                            let pixel = DVec2::new(f64::from(u), f64::from(v));
                            if t == OCCLUDED_STEP && near(camera, WALL_POINT, pixel, 4.0) {
                                return image::Rgb([10, 10, 10]);
                            }
                            if t == 0 && near(camera, PASSING_POINT, pixel, 4.0) {
                                return image::Rgb([230, 20, 20]);
                            }
                            image::Rgb(wall_color(camera.unproject_world(pixel, 5.0)))
                        })
                    })
                    .collect()
            })
            .collect();
        (cameras.into_iter().map(|c| vec![c; STEPS]).collect(), frames)
    }

    fn build(candidates: &[(usize, PointCloud)], options: &StaticOptions) -> StaticCloud {
        let (cameras, frames) = event();
        build_static_cloud(&cameras, |t| Ok::<_, ()>(frames[t].clone()), candidates, options).expect("in memory")
    }

    fn cloud(points: &[[f32; 3]], colors: &[[u8; 3]]) -> PointCloud {
        PointCloud { positions_world: points.to_vec(), colors: colors.to_vec() }
    }

    fn wall(x: f32, y: f32) -> ([f32; 3], [u8; 3]) {
        let p = [x, y, 5.0];
        (p, wall_color(DVec3::new(f64::from(x), f64::from(y), 5.0)))
    }

    #[test]
    fn static_points_found_again_are_kept_once_and_lent_only_where_the_frames_agree() {
        let (q, q_color) = wall(WALL_POINT[0], WALL_POINT[1]);
        let (a, a_color) = wall(-1.0, 0.6);
        let (b, b_color) = wall(0.8, -0.5);
        // A wall point found at one step only: not supported.
        let (stray, stray_color) = wall(-0.6, -0.8);
        let candidates = vec![
            (0, cloud(&[q, a, PASSING_POINT], &[q_color, a_color, [230, 20, 20]])),
            (2, cloud(&[q, b], &[q_color, b_color])),
            (4, cloud(&[a, b, stray], &[a_color, b_color, stray_color])),
        ];
        let options = StaticOptions { min_support_steps: 2, ..StaticOptions::default() };
        let statics = build(&candidates, &options);
        assert_eq!(statics.candidates, 8);
        // The three wall points found twice, each once; neither the passing red thing nor the
        // stray point.
        let mut found = statics.points.positions_world.clone();
        found.sort_by(|x, y| x[0].total_cmp(&y[0]));
        assert_eq!(found, vec![a, q, b]);
        let q_index = statics.points.positions_world.iter().position(|p| *p == q).expect("the wall point") as u32;
        for t in 0..STEPS {
            let active = statics.active[t].contains(&q_index);
            assert_eq!(active, t != OCCLUDED_STEP, "step {t}: the wall point is lent exactly where nothing covers it");
            assert_eq!(statics.borrowed(t).len(), statics.active[t].len());
        }
        assert_eq!(statics.borrowed(1).len(), 3);
        assert_eq!(statics.borrowed(OCCLUDED_STEP).len(), 2);
        assert_eq!(statics.borrowed(STEPS).len(), 0, "no step past the end");
        // With the default support (three steps) none of them is kept.
        assert!(build(&candidates, &StaticOptions::default()).points.is_empty());
    }

    #[test]
    fn a_point_seen_by_one_camera_only_is_not_static() {
        // Far to the side: inside the rightmost camera's image only.
        let (p, color) = wall(3.5, 0.0);
        let visible: Vec<bool> = [-0.5, 0.0, 0.5]
            .iter()
            .map(|&x| camera(x).project_world(DVec3::new(3.5, 0.0, 5.0)).is_some_and(|(q, _)| camera(x).contains(q)))
            .collect();
        assert_eq!(visible, [false, false, true]);
        let statics = build(&[(0, cloud(&[p], &[color]))], &StaticOptions::default());
        assert!(statics.points.is_empty());
    }

    #[test]
    fn candidate_steps_are_spread_over_the_event() {
        assert_eq!(candidate_steps(100, 4), vec![12, 37, 62, 87]);
        assert_eq!(candidate_steps(3, 12), vec![0, 1, 2]);
        assert!(candidate_steps(0, 12).is_empty());
        assert!(candidate_steps(5, 0).is_empty());
    }

    #[test]
    fn own_points_next_to_an_active_static_point_are_left_to_it() {
        let statics = StaticCloud {
            points: cloud(&[[0.05, 0.05, 0.05], [5.05, 0.05, 0.05]], &[[1; 3], [2; 3]]),
            active: vec![vec![0, 1], vec![1]],
            candidates: 2,
            voxel_edge: 0.1,
            ..StaticCloud::default()
        };
        // Same voxel, the neighbouring voxel, two voxels away, and far away.
        let own = cloud(&[[0.01, 0.02, 0.03], [0.15, 0.05, 0.05], [0.25, 0.05, 0.05], [2.0, 2.0, 2.0]], &[[9; 3]; 4]);
        let kept = statics.own_not_covered(0, &own);
        assert_eq!(kept.positions_world, vec![[0.25, 0.05, 0.05], [2.0, 2.0, 2.0]]);
        // At step 1 the first static point is not active (something passed in front of it):
        // the step keeps its own points there.
        assert_eq!(statics.own_not_covered(1, &own).len(), 4);
        assert_eq!(StaticCloud::default().own_not_covered(0, &own).len(), 4, "no static cloud, nothing covered");
    }
}
