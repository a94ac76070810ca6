//! From depth maps to points: the cost threshold, the geometric consistency between views, fusion
//! of the agreeing views, the merge with the sparse points on a voxel grid and the even thinning.

use std::collections::HashMap;

use nalgebra::Vector3;
use rayon::prelude::*;

use super::DensifyOptions;
use super::patchmatch::DepthMap;
use super::view::WorkView;
use crate::mapping::points::TimestepCloud;

/// A dense point before the merge.
pub(super) struct Candidate {
    position_world: Vector3<f64>,
    color: [u8; 3],
    /// Views agreeing on it, its reference included.
    views: u8,
    cost: f32,
}

/// The sparse points with finite coordinates.
pub(super) fn finite_sparse(sparse: &TimestepCloud) -> TimestepCloud {
    let mut out = TimestepCloud::default();
    for (i, p) in sparse.positions_world.iter().enumerate() {
        if p.iter().all(|v| v.is_finite()) {
            out.positions_world.push(*p);
            out.colors.push(sparse.colors.get(i).copied().unwrap_or([0; 3]));
            out.views.push(sparse.views.get(i).copied().unwrap_or(0));
        }
    }
    out
}

/// Depth (m) along the ray through `pixel` of `view` of the plane at the nearest pixel `index`.
fn plane_depth_m(view: &WorkView, map: &DepthMap, index: usize, pixel: (f64, f64)) -> f64 {
    let n = map.normal_camera[index].map(f64::from);
    let n = Vector3::new(n[0], n[1], n[2]);
    let centre = view.ray_camera((index % view.width) as f64, (index / view.width) as f64) * f64::from(map.depth_m[index]);
    let depth = n.dot(&centre) / n.dot(&view.ray_camera(pixel.0, pixel.1));
    if depth.is_finite() && depth > 0.0 { depth } else { f64::from(map.depth_m[index]) }
}

/// The points of every depth map that pass the cost threshold and agree with enough other views,
/// in view and raster order, and the voxel edge (m) that merges duplicates.
pub(super) fn candidates(work: &[Option<WorkView>], maps: &[Option<DepthMap>], options: &DensifyOptions) -> (Vec<Candidate>, f64) {
    let max_cost = 1.0 - options.min_ncc;
    let tolerance = f64::from(options.max_relative_depth_difference);
    let kept = |map: &DepthMap, index: usize| map.depth_m[index] > 0.0 && map.cost[index] <= max_cost;
    // With few depth maps, every other one must agree.
    let required = options.min_consistent_views.min(maps.iter().flatten().count().saturating_sub(1));
    // Where more maps matched than this, this many must agree; a point fewer maps saw keeps the
    // plain requirement.
    let asked_where_matched = options.consistent_views_where_matched;
    let per_view: Vec<Vec<(Candidate, f64)>> = (0..work.len())
        .into_par_iter()
        .map(|r| {
            let (Some(view), Some(map)) = (&work[r], &maps[r]) else { return Vec::new() };
            let mut out = Vec::new();
            for index in 0..map.depth_m.len() {
                if !kept(map, index) {
                    continue;
                }
                let (x, y) = ((index % view.width) as f64, (index / view.width) as f64);
                let depth = f64::from(map.depth_m[index]);
                let point = view.world_at(x, y, depth);
                let (mut sum, mut color, mut count) = (point, view.rgb[index].map(u32::from), 1u32);
                let mut matched = 0usize;
                for (j, (other, other_map)) in work.iter().zip(maps).enumerate() {
                    let (Some(other), Some(other_map)) = (other, other_map) else { continue };
                    if j == r {
                        continue;
                    }
                    let Some((pixel, z)) = other.project(&point) else { continue };
                    let Some(at) = other.index_of(&pixel).filter(|&at| kept(other_map, at)) else { continue };
                    matched += 1;
                    let z_other = plane_depth_m(other, other_map, at, (pixel.x, pixel.y));
                    if (z_other - z).abs() <= tolerance * z {
                        sum += other.world_at(pixel.x, pixel.y, z_other);
                        let c = other.rgb[at];
                        color = [color[0] + u32::from(c[0]), color[1] + u32::from(c[1]), color[2] + u32::from(c[2])];
                        count += 1;
                    }
                }
                let required = if matched > asked_where_matched { required.max(asked_where_matched) } else { required };
                if (count - 1) as usize >= required {
                    let mean = |c: u32| ((c + count / 2) / count).min(255) as u8;
                    let candidate = Candidate {
                        position_world: sum / f64::from(count),
                        color: [mean(color[0]), mean(color[1]), mean(color[2])],
                        views: count.min(255) as u8,
                        cost: map.cost[index],
                    };
                    out.push((candidate, depth / view.focal_px));
                }
            }
            out
        })
        .collect();
    let mut footprints: Vec<f64> = per_view.iter().flatten().map(|(_, f)| *f).collect();
    let voxel_m = if footprints.is_empty() {
        1.0
    } else {
        let middle = footprints.len() / 2;
        *footprints.select_nth_unstable_by(middle, f64::total_cmp).1 * options.voxel_px
    };
    (per_view.into_iter().flatten().map(|(c, _)| c).collect(), voxel_m)
}

/// `count` indices spread evenly over `0..len`.
fn even(len: usize, count: usize) -> impl Iterator<Item = usize> {
    let count = count.min(len);
    (0..count).map(move |i| (i as u128 * len as u128 / count as u128) as usize)
}

/// The sparse points (all of them when they fit) and the dense candidates not in a sparse point's
/// voxel, one per voxel (most agreeing views, then lowest cost), thinned evenly to `target` in all.
pub(super) fn reduce(sparse: &TimestepCloud, candidates: Vec<Candidate>, voxel_m: f64, target: usize) -> TimestepCloud {
    let mut out = TimestepCloud::default();
    let n_sparse = sparse.positions_world.len();
    for i in even(n_sparse, target) {
        out.positions_world.push(sparse.positions_world[i]);
        out.colors.push(sparse.colors[i]);
        out.views.push(sparse.views[i]);
    }
    let remaining = target.saturating_sub(out.positions_world.len());
    if remaining == 0 || candidates.is_empty() {
        return out;
    }
    let voxel_m = if voxel_m.is_finite() && voxel_m > 0.0 { voxel_m } else { 1.0 };
    let key = |p: &Vector3<f64>| [(p.x / voxel_m).floor() as i64, (p.y / voxel_m).floor() as i64, (p.z / voxel_m).floor() as i64];
    // Value: `None` for a sparse point's voxel, else the index of the voxel's dense point.
    let mut voxels: HashMap<[i64; 3], Option<usize>> = sparse.positions_world.iter().map(|p| (key(p), None)).collect();
    let mut dense: Vec<Candidate> = Vec::new();
    for c in candidates {
        match voxels.get(&key(&c.position_world)) {
            Some(None) => {}
            Some(Some(i)) => {
                let held = &dense[*i];
                if c.views > held.views || (c.views == held.views && c.cost < held.cost) {
                    dense[*i] = c;
                }
            }
            None => {
                voxels.insert(key(&c.position_world), Some(dense.len()));
                dense.push(c);
            }
        }
    }
    for i in even(dense.len(), remaining) {
        out.positions_world.push(dense[i].position_world);
        out.colors.push(dense[i].color);
        out.views.push(dense[i].views);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(x: f64, views: u8, cost: f32) -> Candidate {
        Candidate { position_world: Vector3::new(x, 0.0, 0.0), color: [views; 3], views, cost }
    }

    /// A 32 x 32 view at `x_m` on the x axis, looking along +z (focal 32 px).
    fn view_at(x_m: f64) -> WorkView {
        WorkView {
            width: 32,
            height: 32,
            gray: vec![0.5; 1024],
            rgb: vec![[128; 3]; 1024],
            focal_px: 32.0,
            cx_px: 15.5,
            cy_px: 15.5,
            pose: dynview_camera::PoseMatrices { rotation: nalgebra::Matrix3::identity(), center_world: Vector3::new(x_m, 0.0, 0.0) },
        }
    }

    /// Every pixel on a wall 5 m away, matched at no cost.
    fn wall_map() -> DepthMap {
        DepthMap { depth_m: vec![5.0; 1024], normal_camera: vec![[0.0, 0.0, -1.0]; 1024], cost: vec![0.0; 1024] }
    }

    #[test]
    fn a_point_is_kept_only_when_enough_other_depth_maps_agree() {
        let work: Vec<Option<WorkView>> = [0.0, 0.2, 0.4, 0.6, 1.0].into_iter().map(|x| Some(view_at(x))).collect();
        let mut maps: Vec<Option<DepthMap>> = (0..5).map(|_| Some(wall_map())).collect();
        let view = |r: usize| work[r].as_ref().unwrap();
        // A floater 3 m away at view 0's pixel (16, 16), matched the same wrong way by views 1
        // and 2 (as stereo on a dark, plain wall does), not by views 3 and 4, which see the wall.
        let floater = view(0).world_at(16.0, 16.0, 3.0);
        for (r, map) in maps.iter_mut().enumerate().take(3) {
            let (pixel, _) = view(r).project(&floater).unwrap();
            let at = view(r).index_of(&pixel).unwrap();
            map.as_mut().unwrap().depth_m[at] = 3.0;
        }
        // View 4 does not see view 0's wall pixel (5, 5) and view 3 matched nothing where it
        // lands: two other maps can agree on it, no more.
        let corner = view(0).world_at(5.0, 5.0, 5.0);
        assert!(view(4).project(&corner).and_then(|(p, _)| view(4).index_of(&p)).is_none());
        let (pixel, _) = view(3).project(&corner).unwrap();
        let at = view(3).index_of(&pixel).unwrap();
        let (x, y) = (at % 32, at / 32);
        for i in (y - 1..=y + 1).flat_map(|y| (x - 1..=x + 1).map(move |x| y * 32 + x)) {
            maps[3].as_mut().unwrap().depth_m[i] = 0.0;
        }
        let near = |candidates: &[Candidate]| candidates.iter().filter(|c| c.position_world.z < 4.0).count();
        let wall = |candidates: &[Candidate]| candidates.iter().filter(|c| c.position_world.z > 4.0).count();
        let has_corner = |candidates: &[Candidate]| candidates.iter().any(|c| (c.position_world - corner).norm() < 0.05);
        let two =
            DensifyOptions { min_consistent_views: 2, min_ncc: 0.5, max_relative_depth_difference: 0.01, ..DensifyOptions::default() };
        let (kept, _) = candidates(&work, &maps, &two);
        assert!(near(&kept) >= 1, "two other maps agreeing keep the floater");
        assert!(has_corner(&kept));
        let three = DensifyOptions { min_consistent_views: 3, ..two.clone() };
        let (kept, _) = candidates(&work, &maps, &three);
        assert_eq!(near(&kept), 0, "only two other maps agree with the floater");
        assert!(!has_corner(&kept), "three agreeing maps asked for, two can");
        assert!(wall(&kept) > 3000, "the wall, which every map agrees on, stays: {}", wall(&kept));
        // Four other maps matched where the floater lands: asked for three where more than three
        // matched, the floater goes (two agree) and the corner stays (only two maps matched there).
        let matched = DensifyOptions { consistent_views_where_matched: 3, ..two.clone() };
        let (kept, _) = candidates(&work, &maps, &matched);
        assert_eq!(near(&kept), 0, "the fourth matched map outvotes the floater");
        assert!(has_corner(&kept), "where only two maps matched, two agreeing keep the point");
        assert!(wall(&kept) > 3000);
        // With three other maps matched where it lands, two agreeing still keep the floater.
        let (kept, _) = candidates(&work[..4], &maps[..4], &matched);
        assert!(near(&kept) >= 1, "three matched, not more: the plain two suffice");
        // The plates ask for this by default.
        let plates = DensifyOptions { min_ncc: 0.5, ..crate::dense::plate_cloud::PlateCloudOptions::default().densify };
        let (kept, _) = candidates(&work, &maps, &plates);
        assert_eq!(near(&kept), 0, "the plates' defaults drop the floater");
        assert!(has_corner(&kept), "and keep the corner");
    }

    #[test]
    fn even_indices_cover_the_range() {
        assert_eq!(even(10, 5).collect::<Vec<_>>(), [0, 2, 4, 6, 8]);
        assert_eq!(even(3, 5).collect::<Vec<_>>(), [0, 1, 2]);
        assert_eq!(even(0, 5).count(), 0);
    }

    #[test]
    fn reduce_keeps_sparse_points_and_one_dense_point_per_voxel() {
        let sparse = TimestepCloud { positions_world: vec![Vector3::new(0.05, 0.0, 0.0)], colors: vec![[9; 3]], views: vec![3] };
        let candidates = vec![
            candidate(0.02, 5, 0.1), // in the sparse point's voxel: dropped
            candidate(1.01, 2, 0.3),
            candidate(1.02, 3, 0.4), // same voxel, more views: replaces the one before
            candidate(2.5, 2, 0.2),
        ];
        let cloud = reduce(&sparse, candidates, 0.1, 10);
        assert_eq!(cloud.positions_world.len(), 3);
        assert_eq!(cloud.views, [3, 3, 2]);
        assert_eq!(cloud.positions_world[1].x, 1.02);
        let thin = reduce(&sparse, vec![candidate(1.0, 2, 0.1), candidate(2.0, 2, 0.1)], 0.1, 2);
        assert_eq!(thin.positions_world.len(), 2);
        assert_eq!(thin.colors[0], [9; 3], "sparse points first");
    }
}
