//! PatchMatch stereo for one reference view: per pixel a depth and a normal (camera frame),
//! scored by `1 - NCC` through the plane-induced homography into the source views.

use nalgebra::{Matrix3, Vector3};

use super::DensifyOptions;
use super::view::WorkView;

/// Cost of a hypothesis that cannot be scored (out of the source image, degenerate plane).
pub(super) const INVALID_COST: f32 = 2.0;
/// Smallest standard deviation of luma (in `[0, 1]`) in a reference window for it to be matched.
const MIN_WINDOW_STD: f32 = 0.01;
/// Fewest sparse points a view must see to get a depth range (and a depth map).
const MIN_SEEDS: usize = 3;
/// Percentiles of the seeds' depths spanning a view's depth range.
const RANGE_PERCENTILES: (f64, f64) = (0.02, 0.98);
/// Relative depth perturbation of the first refinement (halved every sweep).
const DEPTH_PERTURBATION: f32 = 0.1;
/// Normal perturbation of the first refinement (halved every sweep).
const NORMAL_PERTURBATION: f32 = 0.5;
/// Relative depth below which a neighbour's plane is the pixel's own (not scored again).
const SAME_PLANE_RELATIVE_DEPTH: f32 = 1e-5;
/// Largest window half-size (samples) used, whatever the options say.
const MAX_WINDOW_RADIUS: usize = 7;
/// Largest window stride (px) used, whatever the options say.
const MAX_WINDOW_STRIDE: usize = 8;
/// Most source views per reference.
const MAX_SOURCES: usize = 8;

/// A reference view's depth map at the working resolution.
pub(super) struct DepthMap {
    /// Depth (m, camera z) per pixel; 0 where the pixel was not matched.
    pub depth_m: Vec<f32>,
    /// Unit normal (camera frame, facing the camera) per pixel.
    pub normal_camera: Vec<[f32; 3]>,
    /// Aggregated `1 - NCC` per pixel.
    pub cost: Vec<f32>,
}

/// A source view with its pose relative to the reference.
struct Source<'a> {
    view: &'a WorkView,
    /// `source_from_reference` rotation, row-major.
    rotation: [f32; 9],
    /// `source_from_reference` translation.
    translation: [f32; 3],
}

/// Scores plane hypotheses of reference pixels.
struct Matcher<'a> {
    reference: &'a WorkView,
    sources: Vec<Source<'a>>,
    radius: usize,
    stride: usize,
    best_sources: usize,
    /// Samples per window.
    samples: usize,
    /// Per pixel, its window's luma samples minus their mean, scaled to unit sum of squares; all 0
    /// when the window is untextured.
    windows: Vec<f32>,
    /// Whether each pixel's window is textured enough to be matched.
    textured: Vec<bool>,
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalized(a: [f32; 3]) -> Option<[f32; 3]> {
    let n = dot(a, a).sqrt();
    (n > 1e-12 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

impl<'a> Matcher<'a> {
    fn new(reference: &'a WorkView, sources: Vec<Source<'a>>, options: &DensifyOptions) -> Self {
        let (radius, stride) = (options.window_radius.clamp(1, MAX_WINDOW_RADIUS), options.window_stride.clamp(1, MAX_WINDOW_STRIDE));
        let (w, h) = (reference.width, reference.height);
        let samples = (2 * radius + 1) * (2 * radius + 1);
        let mut windows = vec![0.0; w * h * samples];
        let mut textured = vec![false; w * h];
        let mut values = vec![0.0f32; samples];
        for y in 0..h {
            for x in 0..w {
                for (k, value) in values.iter_mut().enumerate() {
                    let (i, j) = (k % (2 * radius + 1), k / (2 * radius + 1));
                    *value = reference.gray[clamped(y, j, radius, stride, h) * w + clamped(x, i, radius, stride, w)];
                }
                let mean = values.iter().sum::<f32>() / samples as f32;
                let variance = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>();
                if variance / (samples as f32) < MIN_WINDOW_STD * MIN_WINDOW_STD {
                    continue;
                }
                let scale = 1.0 / variance.sqrt();
                let index = y * w + x;
                textured[index] = true;
                for (slot, value) in windows[index * samples..(index + 1) * samples].iter_mut().zip(&values) {
                    *slot = (value - mean) * scale;
                }
            }
        }
        let best_sources = options.best_sources.clamp(1, sources.len().max(1));
        Self { reference, sources, radius, stride, best_sources, samples, windows, textured }
    }

    fn textured(&self, index: usize) -> bool {
        self.textured[index]
    }

    /// Aggregated cost of the plane through `depth_m` at pixel `(x, y)` with `normal`.
    fn cost(&self, x: usize, y: usize, depth_m: f32, normal: [f32; 3]) -> f32 {
        let r = self.reference;
        let (f, cx, cy) = (r.focal_px as f32, r.cx_px as f32, r.cy_px as f32);
        let ray = [(x as f32 - cx) / f, (y as f32 - cy) / f, 1.0];
        let plane = depth_m * dot(normal, ray);
        if !(plane.is_finite() && depth_m.is_finite()) || plane.abs() <= 1e-9 || depth_m <= 0.0 {
            return INVALID_COST;
        }
        let mut costs = [INVALID_COST; MAX_SOURCES];
        for (slot, source) in costs.iter_mut().zip(&self.sources) {
            *slot = self.source_cost(x, y, source, normal, plane).unwrap_or(INVALID_COST);
        }
        let costs = &mut costs[..self.sources.len()];
        costs.sort_unstable_by(f32::total_cmp);
        costs[..self.best_sources].iter().sum::<f32>() / self.best_sources as f32
    }

    /// `1 - NCC` against one source through the homography of the plane `normal . X = plane`.
    fn source_cost(&self, x: usize, y: usize, source: &Source, normal: [f32; 3], plane: f32) -> Option<f32> {
        let (r, s) = (self.reference, source.view);
        // A = R + t n^T / plane maps reference camera points on the plane to source camera points.
        let (rot, t) = (&source.rotation, &source.translation);
        let a: [f32; 9] = std::array::from_fn(|k| rot[k] + t[k / 3] * normal[k % 3] / plane);
        // M = A K_r^-1, then H = K_s M.
        let (fr, cxr, cyr) = (r.focal_px as f32, r.cx_px as f32, r.cy_px as f32);
        let m: [f32; 9] = std::array::from_fn(|k| {
            let row = k / 3;
            match k % 3 {
                0 => a[row * 3] / fr,
                1 => a[row * 3 + 1] / fr,
                _ => a[row * 3 + 2] - (a[row * 3] * cxr + a[row * 3 + 1] * cyr) / fr,
            }
        });
        let (fs, cxs, cys) = (s.focal_px as f32, s.cx_px as f32, s.cy_px as f32);
        let hm: [f32; 9] = std::array::from_fn(|k| match k / 3 {
            0 => fs * m[k] + cxs * m[6 + k % 3],
            1 => fs * m[k] + cys * m[6 + k % 3],
            _ => m[k],
        });
        let (radius, stride) = (self.radius, self.stride);
        let half = (radius * stride) as f32;
        let step = stride as f32;
        let (x0, y0) = (x as f32 - half, y as f32 - half);
        let base = [hm[0] * x0 + hm[1] * y0 + hm[2], hm[3] * x0 + hm[4] * y0 + hm[5], hm[6] * x0 + hm[7] * y0 + hm[8]];
        let dx = [hm[0] * step, hm[3] * step, hm[6] * step];
        let dy = [hm[1] * step, hm[4] * step, hm[7] * step];
        let sw = s.width;
        let index = y * r.width + x;
        let window = &self.windows[index * self.samples..(index + 1) * self.samples];
        let mut k = 0;
        let (max_u, max_v) = ((s.width - 1) as f32, (s.height - 1) as f32);
        let (mut sum_s, mut sum_ss, mut sum_rs) = (0.0f32, 0.0f32, 0.0f32);
        for j in 0..=2 * radius {
            let jf = j as f32;
            let mut q = [base[0] + jf * dy[0], base[1] + jf * dy[1], base[2] + jf * dy[2]];
            for _ in 0..=2 * radius {
                if q[2].is_nan() || q[2] <= 1e-9 {
                    return None;
                }
                let inverse = 1.0 / q[2];
                let (u, v) = (q[0] * inverse, q[1] * inverse);
                if !(u >= 0.0 && v >= 0.0 && u < max_u && v < max_v) {
                    return None;
                }
                let (iu, iv) = (u as usize, v as usize);
                let (fu, fv) = (u - iu as f32, v - iv as f32);
                let p = iv * sw + iu;
                let g = &s.gray;
                let top = g[p] + fu * (g[p + 1] - g[p]);
                let bottom = g[p + sw] + fu * (g[p + sw + 1] - g[p + sw]);
                let value = top + fv * (bottom - top);
                sum_s += value;
                sum_ss += value * value;
                sum_rs += value * window[k];
                k += 1;
                q = [q[0] + dx[0], q[1] + dx[1], q[2] + dx[2]];
            }
        }
        let variance_s = sum_ss - sum_s * sum_s / self.samples as f32;
        if variance_s.is_nan() || variance_s <= 1e-9 {
            return Some(1.0);
        }
        // The reference samples have zero mean and unit sum of squares.
        let ncc = sum_rs / variance_s.sqrt();
        Some(1.0 - ncc.clamp(-1.0, 1.0))
    }
}

/// Coordinate of window sample `k` around `centre`, clamped to the image.
fn clamped(centre: usize, k: usize, radius: usize, stride: usize, size: usize) -> usize {
    (centre + k * stride).saturating_sub(radius * stride).min(size - 1)
}

/// SplitMix64 of the inputs: the random numbers of a pixel, a view and a sweep.
fn random(seed: u64, view: usize, pixel: usize, sweep: usize, k: u64) -> f32 {
    let mut z = seed
        ^ (view as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ (pixel as u64).wrapping_mul(0xbf58_476d_1ce4_e5b9)
        ^ (sweep as u64).wrapping_mul(0x94d0_49bb_1331_11eb)
        ^ k.wrapping_mul(0x2545_f491_4f6c_dd1d);
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}

/// The source views of `reference`: the closest optical axes among the views whose centre differs.
fn sources<'a>(reference: usize, views: &'a [Option<WorkView>], count: usize) -> Vec<Source<'a>> {
    let Some(r) = &views[reference] else { return Vec::new() };
    let mut ranked: Vec<(f64, usize)> = views
        .iter()
        .enumerate()
        .filter_map(|(j, v)| {
            let v = v.as_ref()?;
            let baseline = (v.pose.center_world - r.pose.center_world).norm();
            (j != reference && baseline > 1e-9).then(|| (-v.axis_world().dot(&r.axis_world()), j))
        })
        .filter(|(a, _)| a.is_finite())
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    ranked
        .iter()
        .take(count.clamp(1, MAX_SOURCES))
        .filter_map(|&(_, j)| {
            let s = views[j].as_ref()?;
            let rotation: Matrix3<f64> = s.pose.rotation * r.pose.rotation.transpose();
            let translation: Vector3<f64> = s.pose.rotation * (r.pose.center_world - s.pose.center_world);
            Some(Source {
                view: s,
                rotation: std::array::from_fn(|k| rotation[(k / 3, k % 3)] as f32),
                translation: std::array::from_fn(|k| translation[k] as f32),
            })
        })
        .collect()
}

/// Depths (m) of the sparse points at the reference's pixels (the nearest when several fall on one
/// pixel, spread over 3x3 pixels) and the view's depth range; `None` with too few points in view.
fn seeds(reference: &WorkView, sparse_world: &[Vector3<f64>], margin: f64) -> Option<(Vec<f32>, f32, f32)> {
    let (w, h) = (reference.width, reference.height);
    let mut seed_depth = vec![0.0f32; w * h];
    let mut depths = Vec::new();
    for p in sparse_world {
        let Some((pixel, depth)) = reference.project(p) else { continue };
        let Some(index) = reference.index_of(&pixel) else { continue };
        depths.push(depth);
        let (x, y) = (index % w, index / w);
        for yy in y.saturating_sub(1)..(y + 2).min(h) {
            for xx in x.saturating_sub(1)..(x + 2).min(w) {
                let slot = &mut seed_depth[yy * w + xx];
                if *slot == 0.0 || (depth as f32) < *slot {
                    *slot = depth as f32;
                }
            }
        }
    }
    if depths.len() < MIN_SEEDS {
        return None;
    }
    depths.sort_by(f64::total_cmp);
    let at = |q: f64| depths[((depths.len() - 1) as f64 * q).round() as usize];
    let (near, far) = (at(RANGE_PERCENTILES.0) * (1.0 - margin).max(0.05), at(RANGE_PERCENTILES.1) * (1.0 + margin));
    (near > 0.0 && far > near && far.is_finite()).then_some((seed_depth, near as f32, far as f32))
}

/// The depth map of view `reference`; `None` when it has no frame, no source view or too few
/// sparse points in view.
pub(super) fn depth_map(
    reference: usize,
    views: &[Option<WorkView>],
    sparse_world: &[Vector3<f64>],
    options: &DensifyOptions,
) -> Option<DepthMap> {
    let r = views[reference].as_ref()?;
    let source_list = sources(reference, views, options.source_views);
    if source_list.is_empty() {
        return None;
    }
    let (seed_depth, near, far) = seeds(r, sparse_world, options.depth_range_margin)?;
    let matcher = Matcher::new(r, source_list, options);
    let (w, h) = (r.width, r.height);
    let (f, cx, cy) = (r.focal_px as f32, r.cx_px as f32, r.cy_px as f32);
    let ray = |x: usize, y: usize| [(x as f32 - cx) / f, (y as f32 - cy) / f, 1.0];
    let facing = |n: [f32; 3], ray: [f32; 3]| dot(n, ray) < -0.1 * dot(ray, ray).sqrt();
    let back = |ray: [f32; 3]| normalized([-ray[0], -ray[1], -ray[2]]).unwrap_or([0.0, 0.0, -1.0]);
    let perturbed = |n: [f32; 3], ray: [f32; 3], scale: f32, u: [f32; 3]| {
        let n = normalized([n[0] + scale * (2.0 * u[0] - 1.0), n[1] + scale * (2.0 * u[1] - 1.0), n[2] + scale * (2.0 * u[2] - 1.0)]);
        n.filter(|&n| facing(n, ray))
    };
    let seed = options.seed;
    let mut depth = vec![0.0f32; w * h];
    let mut normal = vec![[0.0f32, 0.0, -1.0]; w * h];
    let mut cost = vec![INVALID_COST; w * h];
    for y in 0..h {
        for x in 0..w {
            let index = y * w + x;
            if !matcher.textured(index) {
                continue;
            }
            let rand = |k| random(seed, reference, index, 0, k);
            let ray = ray(x, y);
            let d = near + rand(0) * (far - near);
            let n = perturbed(back(ray), ray, 0.7, [rand(1), rand(2), rand(3)]).unwrap_or(back(ray));
            let (mut best_d, mut best_n, mut best_c) = (d, n, matcher.cost(x, y, d, n));
            if seed_depth[index] > 0.0 {
                let c = matcher.cost(x, y, seed_depth[index], back(ray));
                if c < best_c {
                    (best_d, best_n, best_c) = (seed_depth[index], back(ray), c);
                }
            }
            (depth[index], normal[index], cost[index]) = (best_d, best_n, best_c);
        }
    }
    for sweep in 0..2 * options.iterations {
        let forward = sweep % 2 == 0;
        let scale = 0.5f32.powi(sweep as i32);
        for k in 0..w * h {
            let index = if forward { k } else { w * h - 1 - k };
            if !matcher.textured(index) {
                continue;
            }
            let (x, y) = (index % w, index / w);
            let ray_p = ray(x, y);
            let (mut best_d, mut best_n, mut best_c) = (depth[index], normal[index], cost[index]);
            let neighbours: [(isize, isize); 2] = if forward { [(-1, 0), (0, -1)] } else { [(1, 0), (0, 1)] };
            for (ox, oy) in neighbours {
                let (nx, ny) = (x as isize + ox, y as isize + oy);
                if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                    continue;
                }
                let q = ny as usize * w + nx as usize;
                if depth[q] <= 0.0 {
                    continue;
                }
                // The neighbour's plane, intersected with this pixel's ray.
                let n = normal[q];
                let ray_q = ray(nx as usize, ny as usize);
                let d = depth[q] * dot(n, ray_q) / dot(n, ray_p);
                let same_plane = n == best_n && (d - best_d).abs() <= SAME_PLANE_RELATIVE_DEPTH * best_d;
                if same_plane || !(d >= 0.5 * near && d <= 2.0 * far) || !facing(n, ray_p) {
                    continue;
                }
                let c = matcher.cost(x, y, d, n);
                if c < best_c {
                    (best_d, best_n, best_c) = (d, n, c);
                }
            }
            // Random refinement: depth and normal perturbed together.
            let rand = |k| random(seed, reference, index, sweep + 1, k);
            let d = best_d * (1.0 + DEPTH_PERTURBATION * scale * (2.0 * rand(0) - 1.0));
            if let Some(n) = perturbed(best_n, ray_p, NORMAL_PERTURBATION * scale, [rand(1), rand(2), rand(3)]) {
                let c = matcher.cost(x, y, d, n);
                if c < best_c {
                    (best_d, best_n, best_c) = (d, n, c);
                }
            }
            (depth[index], normal[index], cost[index]) = (best_d, best_n, best_c);
        }
    }
    for index in 0..w * h {
        if cost[index] >= INVALID_COST {
            depth[index] = 0.0;
        }
    }
    Some(DepthMap { depth_m: depth, normal_camera: normal, cost })
}
