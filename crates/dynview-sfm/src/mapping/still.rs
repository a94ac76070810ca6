//! Cameras that stand still (tripods, a calibrated dome): detected from their own keyframes and
//! reconstructed as one image each.
//!
//! The keyframes of a still camera have no baseline between them, and one time step of a few
//! wide-apart tripods shares few verified matches (40 at most between two Panoptic cameras at
//! 640x360, under the 50 an initial pair needs). But the same two tripods are matched at every
//! time step: static features repeat and the people moving add new ones. So a still camera's
//! keyframes are pooled into one image (features at the same pixel merged), the matches of its
//! keyframe pairs with another camera at the same time step are pooled too and verified again as
//! one two-view geometry, and the model is solved over the pooled images. Its pose is then every
//! keyframe's.
//!
//! Pooling also pools mistakes: a dome of identical panels, lamps and loudspeakers matches the
//! same wrong way at every time step. A pooled geometry is kept only where matches on what moved
//! (features one keyframe alone has) support it ([`MIN_MOVING_INLIERS`]).

use std::collections::{BTreeMap, HashMap};

use crate::error::SfmResult;
use crate::features::guided::guided_matches_fundamental;
use crate::features::matching::{MatchOptions, TwoView, verify};
use crate::features::sift::Features;
use crate::mapping::incremental::{MapPoint, Reconstruction};
use crate::mapping::keyframes::Keyframe;

/// A camera stands still when a quarter of the verified matches between any two of its
/// keyframes moved by at most this (px): the static background stays in place, whatever moves
/// in front of it.
pub const STILL_SHIFT_PX: f64 = 0.5;

/// Features of a still camera's keyframes closer than this (px) are one feature of its pooled
/// image: SIFT finds a static corner within a few tenths of a pixel in every frame.
pub const SAME_FEATURE_PX: f32 = 0.75;

/// Pooled pairs are matched again along the epipolar lines of their pooled fundamental matrix,
/// within this distance (px).
pub const GUIDED_EPIPOLAR_PX: f64 = 2.0;

/// Fewest pooled inliers between features that one keyframe alone has (on either side) for a
/// pooled pair to be kept. Such matches are on what moves (people) or changes, which differs
/// from one time step to the next and so cannot repeat a wrong match the way repeated static
/// structure does. On the Panoptic arc (4 time steps) the right pairs have 27-51 of them, the
/// pairs matched wrongly through the repetitive dome 0-7.
pub const MIN_MOVING_INLIERS: usize = 20;

/// Least share of a pooled pair's inliers that must be such moving matches ([`MIN_MOVING_INLIERS`]):
/// 0.35-0.52 on the right Panoptic pairs over 4 and 15 time steps, 0.33 at most on the wrong.
pub const MIN_MOVING_SHARE: f64 = 0.3;

/// A still camera is pooled only when no single time step verified this many inliers between
/// it and another camera: with such a pair it starts and joins a reconstruction as it is (twice
/// the 50 an initial pair needs; one time step of two Panoptic cameras has at most 40).
/// Richly textured static scenes (the synthetic tripod events) match mostly on their
/// background, so a pooled pair of theirs has too few moving matches to be trusted, while
/// their single time steps need no pooling.
pub const MIN_SINGLE_STEP_INLIERS: usize = 100;

/// The keyframe pairs without those across time between two still cameras: matches across time
/// are wrong on whatever moved in between, and between two still cameras the pairs of one time
/// step already hold every static match. (Pooled cameras' pairs across time are dropped by
/// [`pool`] too.) On a synthetic still arc of 8 cameras over 160 degrees with long lenses (1.2
/// to 1.0 x the longer side), 3 keyframes a camera, the pairs across time left focal lengths
/// up to 5 times too long; without them every one is within 1.1% (`docs/results/sfm.md`, "Found
/// on the way: long lenses on a 160-degree still arc").
pub fn without_pairs_across_time(still: &[bool], keys: &[Keyframe], pairs: &[(usize, usize, TwoView)]) -> Vec<(usize, usize, TwoView)> {
    let is_still = |camera: usize| still.get(camera) == Some(&true);
    pairs
        .iter()
        .filter(|(a, b, _)| {
            let (ka, kb) = (&keys[*a], &keys[*b]);
            !(ka.camera != kb.camera && ka.frame != kb.frame && is_still(ka.camera) && is_still(kb.camera))
        })
        .cloned()
        .collect()
}

/// Which still cameras to pool: those with no pair of [`MIN_SINGLE_STEP_INLIERS`] inliers
/// with another camera at one time step.
pub fn cameras_to_pool(still: &[bool], keys: &[Keyframe], pairs: &[(usize, usize, TwoView)]) -> Vec<bool> {
    let mut rich = vec![false; still.len()];
    for (a, b, v) in pairs {
        let (ka, kb) = (&keys[*a], &keys[*b]);
        if ka.camera != kb.camera && ka.frame == kb.frame && v.inliers.len() >= MIN_SINGLE_STEP_INLIERS {
            for c in [ka.camera, kb.camera] {
                if let Some(r) = rich.get_mut(c) {
                    *r = true;
                }
            }
        }
    }
    still.iter().zip(&rich).map(|(&s, &r)| s && !r).collect()
}

/// Per camera, whether it stands still: it has two keyframes or more, in every verified pair of
/// them a quarter of the matches moved by at most [`STILL_SHIFT_PX`], and those pairs link all
/// of them.
pub fn still_cameras(camera_count: usize, keys: &[Keyframe], features: &[Features], pairs: &[(usize, usize, TwoView)]) -> Vec<bool> {
    let mut shifts: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    for (a, b, v) in pairs {
        if keys[*a].camera == keys[*b].camera && !v.inliers.is_empty() {
            let mut d: Vec<f64> = v
                .inliers
                .iter()
                .map(|m| {
                    let (p, q) = (features[*a].xy[m[0] as usize], features[*b].xy[m[1] as usize]);
                    f64::from((p[0] - q[0]).hypot(p[1] - q[1]))
                })
                .collect();
            d.sort_by(f64::total_cmp);
            shifts.insert((*a, *b), d[d.len() / 4]);
        }
    }
    (0..camera_count)
        .map(|c| {
            let own: Vec<usize> = (0..keys.len()).filter(|&i| keys[i].camera == c).collect();
            let own_shifts: Vec<(&(usize, usize), &f64)> = shifts.iter().filter(|((a, _), _)| keys[*a].camera == c).collect();
            if own.len() < 2 || own_shifts.iter().any(|(_, shift)| **shift > STILL_SHIFT_PX) {
                return false;
            }
            // Every keyframe must be linked to the first through verified pairs.
            let mut joined = vec![own[0]];
            while let Some(next) = own_shifts
                .iter()
                .find_map(|((a, b), _)| (joined.contains(a) != joined.contains(b)).then_some(if joined.contains(a) { *b } else { *a }))
            {
                joined.push(next);
            }
            own.iter().all(|k| joined.contains(k))
        })
        .collect()
}

/// The keyframes with every still camera's pooled into one image.
#[derive(Clone, Debug)]
pub struct Pooled {
    /// One keyframe per image: a still camera's first keyframe stands for all of them.
    pub keys: Vec<Keyframe>,
    /// The images' features (a still camera's: its keyframes' features, repeats merged).
    pub features: Vec<Features>,
    /// Verified matches between the images.
    pub pairs: Vec<(usize, usize, TwoView)>,
    /// Per keyframe, its image.
    pub image_of_key: Vec<usize>,
    /// Per keyframe, per feature, its feature in the image.
    pub feature_of_key: Vec<Vec<u32>>,
    /// Pooled pairs left out because only static matches supported them ([`MIN_MOVING_INLIERS`]).
    pub untrusted_pairs: usize,
}

/// Pools the keyframes of the cameras marked `still` (see the module's comment); the others'
/// keyframes and pairs are kept as they are. Pooled pairs are verified again with `options`.
pub fn pool(
    keys: &[Keyframe],
    features: &[Features],
    pairs: &[(usize, usize, TwoView)],
    still: &[bool],
    options: &MatchOptions,
) -> SfmResult<Pooled> {
    let mut out = Pooled {
        keys: Vec::new(),
        features: Vec::new(),
        pairs: Vec::new(),
        image_of_key: Vec::new(),
        feature_of_key: Vec::new(),
        untrusted_pairs: 0,
    };
    let is_still = |camera: usize| still.get(camera) == Some(&true);
    let mut image_of_camera: HashMap<usize, usize> = HashMap::new();
    let mut grids: HashMap<usize, HashMap<(i32, i32), Vec<u32>>> = HashMap::new();
    for (k, f) in keys.iter().zip(features) {
        if !is_still(k.camera) {
            out.image_of_key.push(out.keys.len());
            out.feature_of_key.push((0..f.len() as u32).collect());
            out.keys.push(*k);
            out.features.push(f.clone());
            continue;
        }
        let image = *image_of_camera.entry(k.camera).or_insert_with(|| {
            out.keys.push(*k);
            out.features.push(Features::default());
            out.keys.len() - 1
        });
        let (merged, grid) = (&mut out.features[image], grids.entry(image).or_default());
        let map = f.xy.iter().enumerate().map(|(j, &xy)| merge_feature(merged, grid, xy, &f.descriptors[j * 128..(j + 1) * 128])).collect();
        out.image_of_key.push(image);
        out.feature_of_key.push(map);
    }
    // Per image, per feature, how many keyframes were pooled into it.
    let mut seen_in: Vec<Vec<u32>> = out.features.iter().map(|f| vec![0; f.len()]).collect();
    for (k, map) in out.feature_of_key.iter().enumerate() {
        for &f in map {
            seen_in[out.image_of_key[k]][f as usize] += 1;
        }
    }
    let mut pooled: BTreeMap<(usize, usize), Vec<[u32; 2]>> = BTreeMap::new();
    for (a, b, v) in pairs {
        let (ia, ib) = (out.image_of_key[*a], out.image_of_key[*b]);
        if ia == ib {
            continue;
        }
        if !is_still(keys[*a].camera) && !is_still(keys[*b].camera) {
            out.pairs.push((ia, ib, v.clone()));
            continue;
        }
        if keys[*a].frame != keys[*b].frame {
            // Matches across time are wrong on whatever moved in between.
            continue;
        }
        let matches = pooled.entry((ia.min(ib), ia.max(ib))).or_default();
        for m in &v.inliers {
            let (fa, fb) = (out.feature_of_key[*a][m[0] as usize], out.feature_of_key[*b][m[1] as usize]);
            matches.push(if ia < ib { [fa, fb] } else { [fb, fa] });
        }
    }
    for ((ia, ib), mut matches) in pooled {
        matches.sort_unstable();
        matches.dedup();
        let (xy_a, xy_b) = (&out.features[ia].xy, &out.features[ib].xy);
        let mut v = verify(xy_a, xy_b, &matches, options)?;
        let moving = v.inliers.iter().filter(|m| seen_in[ia][m[0] as usize] == 1 && seen_in[ib][m[1] as usize] == 1).count();
        if moving < MIN_MOVING_INLIERS || (moving as f64) < MIN_MOVING_SHARE * v.inliers.len() as f64 || v.is_degenerate(options) {
            // Only the static background supports this geometry (or a plane explains it all):
            // repeated structure (a dome's panels, lamps, loudspeakers) matches the same wrong
            // way in every frame.
            out.untrusted_pairs += usize::from(!v.inliers.is_empty());
            continue;
        }
        if let Some(f) = v.fundamental {
            // The pooled geometry finds the matches the ratio test over a whole image lost.
            matches.extend(guided_matches_fundamental(&out.features[ia], &out.features[ib], &f, GUIDED_EPIPOLAR_PX, options.ratio));
            matches.sort_unstable();
            matches.dedup();
            v = verify(xy_a, xy_b, &matches, options)?;
        }
        if !v.inliers.is_empty() {
            out.pairs.push((ia, ib, v));
        }
    }
    out.pairs.sort_by_key(|(a, b, _)| (*a, *b));
    Ok(out)
}

/// The feature of `merged` within [`SAME_FEATURE_PX`] of `xy`, added when there is none.
fn merge_feature(merged: &mut Features, grid: &mut HashMap<(i32, i32), Vec<u32>>, xy: [f32; 2], descriptor: &[u8]) -> u32 {
    let cell = |v: f32| (v / SAME_FEATURE_PX).floor() as i32;
    let (cx, cy) = (cell(xy[0]), cell(xy[1]));
    let near = (cx - 1..=cx + 1).flat_map(|x| (cy - 1..=cy + 1).map(move |y| (x, y))).find_map(|c| {
        grid.get(&c)?.iter().copied().find(|&f| {
            let p = merged.xy[f as usize];
            (p[0] - xy[0]).hypot(p[1] - xy[1]) <= SAME_FEATURE_PX
        })
    });
    near.unwrap_or_else(|| {
        let id = merged.xy.len() as u32;
        merged.xy.push(xy);
        merged.descriptors.extend_from_slice(descriptor);
        grid.entry((cx, cy)).or_default().push(id);
        id
    })
}

/// The reconstruction of the pooled images as one over the keyframes: each keyframe takes its
/// image's pose, and each point is seen by every keyframe feature that was pooled into one it
/// was seen by.
pub fn unpool(pooled: &Pooled, reconstruction: Reconstruction) -> Reconstruction {
    let mut keys_of_feature: HashMap<(usize, u32), Vec<(usize, u32)>> = HashMap::new();
    for (k, map) in pooled.feature_of_key.iter().enumerate() {
        for (j, &f) in map.iter().enumerate() {
            keys_of_feature.entry((pooled.image_of_key[k], f)).or_default().push((k, j as u32));
        }
    }
    let points = reconstruction
        .points
        .into_iter()
        .map(|p| MapPoint {
            xyz: p.xyz,
            observations: p.observations.iter().flat_map(|o| keys_of_feature.get(o).cloned().unwrap_or_default()).collect(),
        })
        .collect();
    let placed_from_pair =
        (0..pooled.image_of_key.len()).filter(|&k| reconstruction.placed_from_pair.contains(&pooled.image_of_key[k])).collect();
    Reconstruction {
        poses: pooled.image_of_key.iter().map(|&i| reconstruction.poses[i]).collect(),
        points,
        placed_from_pair,
        ..reconstruction
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn features(xy: &[[f32; 2]]) -> Features {
        Features { xy: xy.to_vec(), descriptors: vec![0; xy.len() * 128] }
    }

    fn pair(a: usize, b: usize, inliers: &[[u32; 2]]) -> (usize, usize, TwoView) {
        (
            a,
            b,
            TwoView { inliers: inliers.to_vec(), fundamental_inliers: inliers.len(), homography_inliers: inliers.len(), fundamental: None },
        )
    }

    /// Keyframes of cameras 0 and 1 at frames 0 and 5.
    fn two_cameras_two_steps() -> [Keyframe; 4] {
        [0, 1].map(|camera| [0, 5].map(|frame| Keyframe { camera, frame })).concat().try_into().expect("4 keyframes")
    }

    #[test]
    fn pairs_across_time_are_dropped_between_still_cameras_only() {
        // Cameras 0 and 1 (still) at frames 0 and 5, camera 2 (hand-held) at frame 5.
        let mut keys = two_cameras_two_steps().to_vec();
        keys.push(Keyframe { camera: 2, frame: 5 });
        let m = [[0, 0]];
        let pairs = vec![pair(0, 1, &m), pair(0, 2, &m), pair(0, 3, &m), pair(1, 3, &m), pair(2, 4, &m), pair(0, 4, &m)];
        let kept: Vec<(usize, usize)> =
            without_pairs_across_time(&[true, true, false], &keys, &pairs).iter().map(|(a, b, _)| (*a, *b)).collect();
        // Dropped: (0, 3), cameras 0 and 1 across time. Kept: one camera's own keyframes (0, 1),
        // one time step (0, 2) and (1, 3), and pairs with the hand-held camera across time.
        assert_eq!(kept, vec![(0, 1), (0, 2), (1, 3), (2, 4), (0, 4)]);
        // Where neither stands still, nothing is dropped.
        assert_eq!(without_pairs_across_time(&[false, false, false], &keys, &pairs).len(), pairs.len());
    }

    #[test]
    fn still_only_when_every_keyframe_pair_matches_in_place() {
        let keys = two_cameras_two_steps();
        let f0 = features(&[[10.0, 10.0], [50.0, 20.0], [30.0, 40.0]]);
        let in_place = features(&[[10.2, 10.1], [50.0, 19.8], [30.1, 40.0]]);
        let moved = features(&[[14.0, 10.0], [54.0, 20.0], [34.0, 40.0]]);
        let all = [[0, 0], [1, 1], [2, 2]];
        let pairs = vec![pair(0, 1, &all), pair(2, 3, &all)];
        assert_eq!(still_cameras(3, &keys, &[f0.clone(), in_place, f0.clone(), moved], &pairs), vec![true, false, false]);
        // A keyframe pair that did not match at all says nothing: not still.
        assert_eq!(still_cameras(2, &keys, &[f0.clone(), f0.clone(), f0.clone(), f0], &pairs[..1]), vec![true, false]);
    }

    #[test]
    fn pooling_merges_repeats_and_unpooling_restores_every_keyframe() {
        let keys = [Keyframe { camera: 0, frame: 0 }, Keyframe { camera: 0, frame: 5 }];
        let f = [features(&[[10.0, 10.0], [50.0, 20.0]]), features(&[[10.3, 9.8], [70.0, 70.0]])];
        let pooled = pool(&keys, &f, &[pair(0, 1, &[[0, 0]])], &[true], &MatchOptions::default()).expect("pool");
        assert_eq!(pooled.keys.len(), 1);
        assert_eq!(pooled.features[0].xy, vec![[10.0, 10.0], [50.0, 20.0], [70.0, 70.0]]);
        assert_eq!(pooled.feature_of_key, vec![vec![0, 1], vec![0, 2]]);
        assert!(pooled.pairs.is_empty(), "a camera is not paired with itself");
        let pose = dynview_camera::Rigid3::IDENTITY;
        let r = Reconstruction {
            intrinsics: vec![],
            poses: vec![Some(pose)],
            points: vec![MapPoint { xyz: nalgebra::Vector3::new(0.0, 0.0, 1.0), observations: vec![(0, 0)] }],
            principal_point_std_px: vec![],
            focal_std_px: vec![],
            principal_point_refined: false,
            placed_from_pair: vec![0],
            focal_restarts: vec![],
        };
        let back = unpool(&pooled, r);
        assert_eq!(back.poses, vec![Some(pose), Some(pose)]);
        assert_eq!(back.points[0].observations, vec![(0, 0), (1, 0)]);
        assert_eq!(back.placed_from_pair, vec![0, 1]);
    }

    /// Pixels of `points` in a camera of focal 500 px at the centre of a 640x360 image, turned by
    /// `yaw_rad` about the vertical and standing at `center`.
    fn project(points: &[[f64; 3]], yaw_rad: f64, center: [f64; 3]) -> Vec<[f32; 2]> {
        let (s, c) = yaw_rad.sin_cos();
        points
            .iter()
            .map(|p| {
                let d = [p[0] - center[0], p[1] - center[1], p[2] - center[2]];
                let (x, y, z) = (c * d[0] - s * d[2], d[1], s * d[0] + c * d[2]);
                [(320.0 + 500.0 * x / z) as f32, (180.0 + 500.0 * y / z) as f32]
            })
            .collect()
    }

    /// `n` points in a box 4-8 m in front of the origin (a fixed pseudo-random sequence).
    fn scene(n: usize, seed: u64) -> Vec<[f64; 3]> {
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n).map(|_| [next() * 4.0 - 2.0, next() * 2.0 - 1.0, 4.0 + next() * 4.0]).collect()
    }

    #[test]
    fn a_pooled_pair_is_kept_only_where_what_moved_supports_it() {
        let keys = two_cameras_two_steps();
        let background = scene(60, 1);
        let run = |moving: usize| {
            let people = [scene(moving, 2), scene(moving, 3)];
            let mut images = Vec::new();
            for (yaw, center) in [(0.0, [0.0, 0.0, 0.0]), (-0.3, [1.5, 0.0, 0.3])] {
                for step in &people {
                    let points: Vec<[f64; 3]> = background.iter().chain(step).copied().collect();
                    images.push(features(&project(&points, yaw, center)));
                }
            }
            let all: Vec<[u32; 2]> = (0..(60 + moving) as u32).map(|i| [i, i]).collect();
            // The two time steps, and a pair across time, whose matches on people would be wrong.
            let pairs = vec![pair(0, 2, &all), pair(1, 3, &all), pair(0, 3, &all[..60])];
            pool(&keys, &images, &pairs, &[true, true], &MatchOptions::default()).expect("pool")
        };
        let static_only = run(0);
        assert_eq!(static_only.features[0].len(), 60, "the background is one set of features");
        assert!(static_only.pairs.is_empty(), "repeated static matches alone prove nothing");
        assert_eq!(static_only.untrusted_pairs, 1);
        let with_people = run(30);
        assert_eq!(with_people.features[0].len(), 120);
        assert_eq!((with_people.pairs.len(), with_people.untrusted_pairs), (1, 0));
        assert!(with_people.pairs[0].2.inliers.len() >= 110, "{} inliers", with_people.pairs[0].2.inliers.len());
    }
}
