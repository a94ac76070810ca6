//! Clocks from the pictures: with every camera placed (a given calibration), the time offset
//! between two cameras is the one at which the features of what moves in one camera's frame
//! lie on the epipolar lines of the same features in the other's.
//!
//! Per camera, the moving pixels are those that differ from its median frame (a camera on a
//! tripod); SIFT features are taken there only, so the static scene, which matches at every
//! offset, does not vote. For each pair of neighbouring cameras and each candidate offset (one
//! bin per frame of the second camera, within [`VisualOptions::max_offset_s`]), sampled frames
//! of the first are matched with the frame of the second at that offset, guided by the
//! calibration's epipolar geometry; the offset with the most matches wins, sharpened below a
//! frame by how the matched points move between frames. The pairs' offsets are then solved
//! together, dropping pairs that disagree.

use std::sync::atomic::AtomicBool;

use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};
use opencv::core::{Mat, Size};
use opencv::imgproc;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use dynview_camera::{Model, OpenCv, OpenCvDistortion, Pinhole, Radial, Rigid3};
use dynview_core::StageProgress;
use dynview_interchange::poses::CameraPoses;
use dynview_sync::Clock;
use dynview_sync::timeline::{CameraTimes, nearest};

use crate::error::{SfmError, SfmResult};
use crate::estimators::geometry::essential_between;
use crate::features::guided::{guided_matches, squared_distance};
use crate::features::sift::{DESCRIPTOR_LEN, FeatureOptions, Features, extract_gray_masked, read_gray};
use crate::input::calibration::recorded_frame_poses;
use crate::input::frames::RecordedCamera;
use crate::input::timing::moving::{compensated_still, median_image, moving_mask};
pub use crate::input::timing::solve::PairOffset;
use crate::input::timing::solve::{groups, solve_offsets};

/// How offsets are found from the pictures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VisualOptions {
    /// Largest offset (s) looked for between two cameras' video times.
    pub max_offset_s: f64,
    /// Frames of the first camera of a pair matched at every candidate offset.
    pub sampled_frames: usize,
    /// Frames are worked on at this longest side (px).
    pub max_side_px: u32,
    /// Frames whose median over the recording makes the camera's still image.
    pub median_frames: usize,
    /// A pixel moves where its grey level differs from the still image by more than this.
    pub moving_threshold: f64,
    /// Features of a moving region per frame, at most.
    pub max_features: usize,
    /// Largest distance (px, full size) of a match from its epipolar line.
    pub max_epipolar_px: f64,
    /// Each camera is paired with this many others, nearest in viewing direction first.
    pub neighbours: usize,
    /// A pair's best offset needs this many matches summed over its sampled frames.
    pub min_matches: usize,
}

impl Default for VisualOptions {
    fn default() -> Self {
        Self {
            max_offset_s: 2.0,
            sampled_frames: 24,
            max_side_px: 640,
            median_frames: 15,
            moving_threshold: 25.0,
            max_features: 400,
            max_epipolar_px: 1.0,
            neighbours: 3,
            min_matches: 12,
        }
    }
}

impl VisualOptions {
    /// Checks every option's range.
    pub fn validate(&self) -> SfmResult<()> {
        let bad = |problem: String| Err(SfmError::Option { option: "sync-max-offset", problem });
        if !(self.max_offset_s.is_finite() && (0.05..=600.0).contains(&self.max_offset_s)) {
            return bad(format!("must be in [0.05, 600] s, found {}", self.max_offset_s));
        }
        let counts = [self.sampled_frames, self.median_frames, self.max_features, self.neighbours, self.min_matches];
        if counts.iter().any(|c| *c == 0 || *c > 100_000) || !(16..=8192).contains(&self.max_side_px) {
            return Err(SfmError::Option { option: "visual_sync", problem: format!("counts out of range: {self:?}") });
        }
        if !(self.moving_threshold.is_finite()
            && self.max_epipolar_px.is_finite()
            && self.moving_threshold > 0.0
            && self.max_epipolar_px > 0.0)
        {
            return Err(SfmError::Option { option: "visual_sync", problem: format!("thresholds must be positive: {self:?}") });
        }
        Ok(())
    }
}

/// One camera ready for matching: its moving features per frame (undistorted pixels, full
/// size) and its geometry.
struct View {
    name: String,
    times_s: Vec<f64>,
    /// Its frame rate ([`CameraTimes::nominal_fps`]).
    fps: Option<f64>,
    features: Vec<Features>,
    pinhole: Radial,
    /// Per frame, its pose (a camera without one for a frame keeps its first).
    camera_from_world: Vec<Rigid3>,
    /// Whether its frames' poses differ (hand-held).
    moves: bool,
}

impl View {
    /// The essential matrix from frame `i` of `self` to frame `j` of `other`.
    fn essential_to(&self, i: usize, other: &View, j: usize) -> Matrix3<f64> {
        essential_between(&self.camera_from_world[i], &other.camera_from_world[j])
    }
}

/// Clocks of `recorded` against the first camera's video time from the pictures, each with a
/// confidence, and the pairs' measurements. `calibration` is in the same order as `recorded`.
pub fn visual_clocks(
    recorded: &[RecordedCamera],
    times: &[CameraTimes],
    calibration: &[&CameraPoses],
    options: &VisualOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<(Vec<Clock>, Vec<f64>, Vec<PairOffset>)> {
    let n = recorded.len();
    let mut views = Vec::with_capacity(n);
    for (i, (r, calib)) in recorded.iter().zip(calibration).enumerate() {
        progress("visual sync: moving features", i as u64, n as u64);
        SfmError::check_interrupt(interrupt)?;
        views.push(prepare_view(r, &times[i], calib, options)?);
    }
    progress("visual sync: moving features", n as u64, n as u64);
    let measure = |pairs: &[(usize, usize)]| -> Vec<PairOffset> {
        pairs
            .par_iter()
            .filter_map(|&(a, b)| {
                pair_offset(&views, a, b, options).map(|(offset_s, matches, confidence)| PairOffset {
                    cameras: [a, b],
                    offset_s,
                    matches,
                    confidence,
                })
            })
            .collect()
    };
    let mut tried = neighbour_pairs(&views, options.neighbours);
    progress("visual sync: pairs", 0, tried.len() as u64);
    let mut measured = measure(&tried);
    // Groups of cameras the neighbours leave apart are joined by the nearest pairs across.
    loop {
        SfmError::check_interrupt(interrupt)?;
        let group = groups(n, &measured);
        let mut across: Vec<(f64, usize, usize)> = (0..n)
            .flat_map(|a| (a + 1..n).map(move |b| (a, b)))
            .filter(|&(a, b)| group[a] != group[b] && !tried.contains(&(a, b)))
            .map(|(a, b)| (-axis(&views[a]).dot(&axis(&views[b])), a, b))
            .collect();
        if across.is_empty() {
            break;
        }
        across.sort_by(|x, y| x.0.total_cmp(&y.0));
        let next: Vec<(usize, usize)> = across.iter().take(ACROSS_PAIRS).map(|&(_, a, b)| (a, b)).collect();
        tried.extend(&next);
        measured.extend(measure(&next));
    }
    progress("visual sync: pairs", tried.len() as u64, tried.len() as u64);
    // Half the shortest frame interval: the sub-frame estimates of right pairs agree far better.
    let frame_s = times.iter().filter_map(CameraTimes::nominal_fps).map(|f| 1.0 / f).fold(f64::INFINITY, f64::min);
    let frame_s = if frame_s.is_finite() { frame_s } else { 1.0 / 30.0 };
    let (offsets, confidence) = solve_offsets(n, &measured, frame_s / 2.0).map_err(|unplaced| {
        SfmError::TimeAlignment(format!(
            "--sync visual: camera {} shares no moving features with the others at any offset within {} s",
            views[unplaced].name, options.max_offset_s
        ))
    })?;
    Ok((offsets.iter().map(|o| Clock { start_s: *o, rate: 1.0 }).collect(), confidence, measured))
}

fn prepare_view(recorded: &RecordedCamera, times: &CameraTimes, calib: &CameraPoses, options: &VisualOptions) -> SfmResult<View> {
    let frames = &recorded.frames;
    let scale = (f64::from(options.max_side_px) / f64::from(frames.width.max(frames.height))).min(1.0);
    let size = Size::new((f64::from(frames.width) * scale).round() as i32, (f64::from(frames.height) * scale).round() as i32);
    let gray: Vec<Mat> = frames
        .files
        .par_iter()
        .map(|f| {
            let full = read_gray(f)?;
            let mut small = Mat::default();
            imgproc::resize(&full, &mut small, size, 0.0, 0.0, imgproc::INTER_AREA).map_err(SfmError::cv("downscaling a frame"))?;
            Ok(small)
        })
        .collect::<SfmResult<_>>()?;
    let poses = frame_poses(recorded, calib)?;
    let moves = poses.windows(2).any(|w| w[0] != w[1]);
    // A camera on a tripod has one still image; a hand-held one, one per frame.
    let still = if moves { None } else { Some(median_image(&gray, options.median_frames)?) };
    let pinhole_in = Pinhole::from(calib.intrinsics);
    let lens = OpenCv { pinhole: pinhole_in, distortion: OpenCvDistortion::from_array(calib.distortion) };
    let feature_options = FeatureOptions { max_features: options.max_features, max_image_size_px: u32::MAX, ..FeatureOptions::default() };
    let features: Vec<Features> = gray
        .par_iter()
        .enumerate()
        .map(|(k, g)| {
            let own;
            let still = match &still {
                Some(still) => still,
                None => {
                    own = compensated_still(&gray, k)?;
                    &own
                }
            };
            let mask = moving_mask(g, still, options.moving_threshold)?;
            let mut f = extract_gray_masked(g, &mask, &feature_options)?;
            for xy in &mut f.xy {
                let full = [(f64::from(xy[0]) + 0.5) / scale - 0.5, (f64::from(xy[1]) + 0.5) / scale - 0.5];
                let undistorted = pinhole_in.pixel_from_normalized(lens.normalized_from_pixel(full));
                *xy = [undistorted[0] as f32, undistorted[1] as f32];
            }
            Ok(f)
        })
        .collect::<SfmResult<_>>()?;
    Ok(View {
        name: frames.name.clone(),
        times_s: times.frame_times_s.clone(),
        fps: times.nominal_fps(),
        features,
        pinhole: Radial::from_pinhole(&pinhole_in),
        camera_from_world: poses,
        moves,
    })
}

/// Each recorded frame's pose in `calib`, found by the frame's file name. A frame without one
/// takes the camera between the registered frames around it (a camera placed from its
/// keyframes), or the nearest registered frame's pose at the ends (a calibration of cameras on
/// tripods gives one pose for all).
fn frame_poses(recorded: &RecordedCamera, calib: &CameraPoses) -> SfmResult<Vec<Rigid3>> {
    let name = &recorded.frames.name;
    let first = calib
        .frames
        .iter()
        .find_map(|f| f.camera_from_world)
        .ok_or_else(|| SfmError::TimeAlignment(format!("--sync visual: camera {name} has no pose in the calibration")))?
        .camera_from_world();
    let registered: Vec<(usize, Rigid3)> = recorded_frame_poses(calib, &recorded.frames)
        .into_iter()
        .enumerate()
        .filter_map(|(k, pose)| Some((k, pose?.camera_from_world())))
        .collect();
    Ok((0..recorded.frames.files.len())
        .map(|k| {
            let after = registered.partition_point(|(f, _)| *f < k);
            match (after.checked_sub(1).map(|b| &registered[b]), registered.get(after)) {
                (_, Some((f, pose))) if *f == k => *pose,
                (Some((fa, a)), Some((fb, b))) => a.camera_between(b, (k - fa) as f64 / (fb - fa) as f64),
                (Some((_, pose)), None) | (None, Some((_, pose))) => *pose,
                (None, None) => first,
            }
        })
        .collect())
}

/// A camera's viewing direction in the world.
fn axis(view: &View) -> Vector3<f64> {
    view.camera_from_world[0].rotation_matrix().row(2).transpose()
}

/// Each camera with its `k` nearest in viewing direction (each pair once, first index lower).
fn neighbour_pairs(views: &[View], k: usize) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for a in 0..views.len() {
        let mut others: Vec<(f64, usize)> =
            (0..views.len()).filter(|b| *b != a).map(|b| (-axis(&views[a]).dot(&axis(&views[b])), b)).collect();
        others.sort_by(|x, y| x.0.total_cmp(&y.0));
        for &(_, b) in others.iter().take(k) {
            let pair = (a.min(b), a.max(b));
            if !pairs.contains(&pair) {
                pairs.push(pair);
            }
        }
    }
    pairs
}

/// Pairs measured at once between groups of cameras the neighbours leave apart (several, so
/// that one wrong pair is outvoted).
const ACROSS_PAIRS: usize = 3;

/// Offsets this close to the best (s) are not its rivals for the confidence.
const NEAR_OFFSET_S: f64 = 0.15;

/// A frame of the first camera, a frame of the second and their matches.
type FrameMatches = (usize, usize, Vec<[u32; 2]>);

/// The best offset of camera `b` against camera `a`, its matches and confidence; `None` when
/// too few moving features match at any offset. The candidate offsets step by a frame of the
/// faster camera of the two.
fn pair_offset(views: &[View], a: usize, b: usize, options: &VisualOptions) -> Option<(f64, usize, f64)> {
    if views[a].fps.unwrap_or(0.0) > views[b].fps.unwrap_or(0.0) {
        return pair_offset_stepping_by_b(views, b, a, options).map(|(offset_s, matches, confidence)| (-offset_s, matches, confidence));
    }
    pair_offset_stepping_by_b(views, a, b, options)
}

/// [`pair_offset`] with candidate offsets a frame of `b` apart.
fn pair_offset_stepping_by_b(views: &[View], a: usize, b: usize, options: &VisualOptions) -> Option<(f64, usize, f64)> {
    let (va, vb) = (&views[a], &views[b]);
    let frame_b_s = 1.0 / vb.fps?;
    let bins = (options.max_offset_s / frame_b_s).ceil() as i64;
    let bin_count = (2 * bins + 1) as usize;
    // Sampled frames of a, away from its ends by the search range where it can.
    let samples = sample_frames(&va.times_s, options.sampled_frames, options.max_offset_s);
    let mut best_pairs: Vec<Vec<FrameMatches>> = vec![Vec::new(); bin_count];
    for &i in &samples {
        let t = va.times_s[i];
        for (bin, pairs) in best_pairs.iter_mut().enumerate() {
            let offset = (bin as i64 - bins) as f64 * frame_b_s;
            let j = nearest(&vb.times_s, t + offset);
            if (vb.times_s[j] - (t + offset)).abs() > frame_b_s / 2.0 {
                continue;
            }
            let e = va.essential_to(i, vb, j);
            let matches = guided_matches((&va.features[i], &va.pinhole), (&vb.features[j], &vb.pinhole), &e, options.max_epipolar_px, 0.8);
            pairs.push((i, j, matches));
        }
    }
    // Offsets near the winner match nearly as well (things move little in a few frames).
    let near_bins = ((NEAR_OFFSET_S / frame_b_s).ceil() as usize).max(2);
    if va.moves || vb.moves {
        // A hand-held camera's moving pixels let some of the static scene through. On tripods
        // the median still image leaves little of it, and dropping cost right matches on small
        // frames (at 320x180 a clock 11.9 ms off, against a quarter frame asked).
        drop_static_matches(&mut best_pairs, 2 * near_bins);
    }
    let votes: Vec<usize> = best_pairs.iter().map(|pairs| pairs.iter().map(|(_, _, m)| m.len()).sum()).collect();
    let (winner, &count) = votes.iter().enumerate().max_by_key(|(_, c)| **c)?;
    if count < options.min_matches {
        return None;
    }
    // The runner-up is the best beyond the offsets near the winner.
    let runner_up = votes.iter().enumerate().filter(|(bin, _)| bin.abs_diff(winner) > near_bins).map(|(_, c)| *c).max().unwrap_or(0);
    let confidence = 1.0 - runner_up as f64 / count as f64;
    // Without a refinement, the frames actually matched (picked nearest to each coarse offset).
    let measured: Vec<f64> = best_pairs[winner].iter().map(|(i, j, _)| vb.times_s[*j] - va.times_s[*i]).collect();
    let coarse = if measured.is_empty() { (winner as i64 - bins) as f64 * frame_b_s } else { median(measured) };
    let offset = refine_offset(va, vb, &best_pairs[winner], frame_b_s).unwrap_or(coarse);
    Some((offset, count, confidence))
}

/// Drops from `by_bin` (per candidate offset, the sampled frames' matches) the matches of every
/// feature of a sampled frame that matched at offsets more than `spread_bins` apart: it lies on
/// its epipolar line whatever the time, so it is on the static scene (a hand-held camera's
/// moving pixels let some through; with each frame's own pose they match at every offset), and
/// it would lift every offset alike.
fn drop_static_matches(by_bin: &mut [Vec<FrameMatches>], spread_bins: usize) {
    let mut span: HashMap<(usize, u32), (usize, usize)> = HashMap::new();
    for (bin, pairs) in by_bin.iter().enumerate() {
        for (i, _, matches) in pairs {
            for m in matches {
                let s = span.entry((*i, m[0])).or_insert((bin, bin));
                *s = (s.0.min(bin), s.1.max(bin));
            }
        }
    }
    for pairs in by_bin.iter_mut() {
        for (i, _, matches) in pairs.iter_mut() {
            matches.retain(|m| span.get(&(*i, m[0])).is_some_and(|(lo, hi)| hi - lo <= spread_bins));
        }
    }
}

/// Up to `count` frames spread over the recording, `margin_s` from its ends where it is long
/// enough.
fn sample_frames(times_s: &[f64], count: usize, margin_s: f64) -> Vec<usize> {
    let (first, last) = (times_s[0], times_s[times_s.len() - 1]);
    let (lo, hi) = if last - first > 4.0 * margin_s { (first + margin_s, last - margin_s) } else { (first, last) };
    (0..count.max(1)).map(|k| nearest(times_s, lo + (hi - lo) * (k as f64 + 0.5) / count.max(1) as f64)).collect()
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// The pair's offset (b's video time minus a's) at which the matched points of `b`, moved along
/// their motion, lie on their epipolar lines: each match's frames give a base offset (the
/// frames' times) and a velocity (the same feature in `b`'s next and previous frames, over
/// their real time apart, so variable frame rates count), and the offset is the least-squares
/// fit of `distance + (offset - base) * velocity = 0` over them, the worst fifth dropped once,
/// kept within `max_shift_s` of the median base.
fn refine_offset(a: &View, b: &View, pairs: &[FrameMatches], max_shift_s: f64) -> Option<f64> {
    // Per match and neighbour frame: (base offset s, distance, velocity per s).
    let mut samples: Vec<(f64, f64, f64)> = Vec::new();
    for (i, j, matches) in pairs {
        let base = b.times_s[*j] - a.times_s[*i];
        for next in [j.checked_add(1), j.checked_sub(1)].into_iter().flatten().filter(|k| *k < b.features.len()) {
            let dt = b.times_s[next] - b.times_s[*j];
            if dt.abs() < 1e-6 {
                continue;
            }
            for m in matches {
                let from = b.features[*j].xy[m[1] as usize];
                let Some(to) = same_feature(&b.features[*j], m[1] as usize, &b.features[next], MAX_MOTION_PX) else { continue };
                let xa = a.features[*i].xy[m[0] as usize];
                let ray_a = a.pinhole.normalized(nalgebra::Vector2::new(f64::from(xa[0]), f64::from(xa[1])));
                let ray_a = Vector3::new(ray_a.x, ray_a.y, 1.0);
                // The line in each of b's frames, from that frame's pose (a hand-held camera's
                // own motion moves the line, not only what is filmed).
                let distance = |frame: usize, xy: [f32; 2]| {
                    let line = a.essential_to(*i, b, frame) * ray_a;
                    let n = b.pinhole.normalized(nalgebra::Vector2::new(f64::from(xy[0]), f64::from(xy[1])));
                    line.dot(&Vector3::new(n.x, n.y, 1.0)) / line.x.hypot(line.y).max(1e-12)
                };
                let d0 = distance(*j, from);
                samples.push((base, d0, (distance(next, to) - d0) / dt));
            }
        }
    }
    if samples.len() < 6 {
        return None;
    }
    let mut bases: Vec<f64> = samples.iter().map(|s| s.0).collect();
    bases.sort_by(f64::total_cmp);
    let middle = bases[bases.len() / 2];
    let solve = |set: &[(f64, f64, f64)]| {
        let (num, den) = set.iter().fold((0.0, 0.0), |(num, den), (base, d, w)| (num + w * (w * base - d), den + w * w));
        (den > 1e-12).then(|| (num / den).clamp(middle - max_shift_s, middle + max_shift_s))
    };
    let first = solve(&samples)?;
    let residual = |s: &(f64, f64, f64)| (s.1 + (first - s.0) * s.2).abs();
    samples.sort_by(|x, y| residual(x).total_cmp(&residual(y)));
    samples.truncate(samples.len() * 4 / 5);
    solve(&samples)
}

/// Farthest (px, full size) a feature is looked for in the next frame.
const MAX_MOTION_PX: f32 = 40.0;

/// Where feature `k` of `from` is in `to`: the nearest descriptor among `to`'s features within
/// `radius_px`, passing the ratio test.
fn same_feature(from: &Features, k: usize, to: &Features, radius_px: f32) -> Option<[f32; 2]> {
    let xy = from.xy[k];
    let descriptor = &from.descriptors[k * DESCRIPTOR_LEN..(k + 1) * DESCRIPTOR_LEN];
    let (mut best, mut second) = ((u32::MAX, usize::MAX), u32::MAX);
    for (q, other) in to.xy.iter().enumerate() {
        if (other[0] - xy[0]).hypot(other[1] - xy[1]) > radius_px {
            continue;
        }
        let d = squared_distance(descriptor, &to.descriptors[q * DESCRIPTOR_LEN..(q + 1) * DESCRIPTOR_LEN]);
        if d < best.0 {
            second = best.0;
            best = (d, q);
        } else if d < second {
            second = d;
        }
    }
    (best.1 != usize::MAX && (second == u32::MAX || f64::from(best.0) < 0.64 * f64::from(second))).then(|| to.xy[best.1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn features_matched_at_offsets_far_apart_are_dropped_as_static() {
        // Frame 3's feature 7 matches at offsets 0 and 40 (the static scene); its feature 9
        // matches at offsets 20-22 only (what moves); frame 5's feature 7 matches at offset 21.
        let mut by_bin: Vec<Vec<FrameMatches>> = vec![Vec::new(); 41];
        by_bin[0].push((3, 0, vec![[7, 1]]));
        by_bin[40].push((3, 40, vec![[7, 2]]));
        for (bin, pairs) in by_bin.iter_mut().enumerate().skip(20).take(3) {
            pairs.push((3, bin, vec![[9, 4], [7, 5]]));
        }
        by_bin[21].push((5, 21, vec![[7, 6]]));
        drop_static_matches(&mut by_bin, 6);
        let left: Vec<(usize, usize, u32)> = by_bin
            .iter()
            .enumerate()
            .flat_map(|(bin, pairs)| pairs.iter().flat_map(move |(i, _, m)| m.iter().map(move |m| (bin, *i, m[0]))))
            .collect();
        assert_eq!(left, vec![(20, 3, 9), (21, 3, 9), (21, 5, 7), (22, 3, 9)]);
    }
}
