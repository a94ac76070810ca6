//! The visual hull of what moves at one time step (issue 35): points on the front of the space
//! that every still camera's foreground allows, for moving things that stereo leaves without
//! points (a plain shirt, a ball, a person near one camera that the others see at a wide angle).
//!
//! 1. A camera's foreground ([`foreground`]) is where its frame differs from its background
//!    [plate](super::plates) by more than [`HullOptions::foreground_tolerance`] (or, with
//!    [`ForegroundModel::Soft`], where colour and texture make that likely), opened by
//!    [`HullOptions::open_px`] (compression noise and single pixels of flicker go) and closed by
//!    [`HullOptions::close_px`] (small holes where it looks like the wall are filled); where the
//!    plate is unsure ([`HullOptions::min_plate_confidence`]) nothing is known.
//! 2. Rays leave each camera on a grid of foreground pixels ([`HullOptions::rays_across`]), finer
//!    in a small connected region of the foreground so that it gets at least
//!    [`HullOptions::min_region_rays`] (a ball far from the cameras). A ray through a
//!    foreground pixel of a camera is sampled from near to far, evenly in
//!    inverse depth; a sample is *inside* the hull when no other camera that sees it calls its
//!    pixel background (the foreground grown by [`HullOptions::carve_dilation_px`], for
//!    calibration error; up to [`HullOptions::max_background_votes`] may) and at least [`HullOptions::min_witnesses`] of them call it
//!    foreground. The first inside sample, refined by bisection, is where the ray enters the
//!    hull: a point there, with the pixel's colour.
//! 3. The step's own points rule where they stand on the hull's front (a visual hull is never
//!    smaller than the object; stereo points are exact where there are any): a hull point is
//!    dropped when an own point projects into its cell within [`HullOptions::own_point_band`]
//!    behind it. Where its cell has none but cells within [`HullOptions::own_point_reach`] of
//!    it do, on the camera's foreground and between where the ray enters the hull and where it
//!    leaves it, the point moves back onto the surface they give (their depths weighted by
//!    nearness): a hull carved by cameras on an arc reaches well in front of a flat face (a
//!    box's front seen from 60 degrees: 0.9 of its width), while stereo finds the face's edges.
//!
//! Only cameras with a plate take part (a camera that moves has no plate); a camera outside
//! whose image a sample falls says nothing about it.

use dynview_core::Camera;
use dynview_core::raster::ScalarRaster;
use dynview_core::scene::PointCloud;
use glam::DVec2;
use opencv::core::{CV_32S, Mat};
use opencv::imgproc;
use opencv::prelude::*;
use rayon::prelude::*;

use crate::error::{SfmError, SfmResult};

mod foreground;
mod options;
pub use foreground::{Foreground, foreground};
pub use options::{ForegroundModel, HullOptions};

/// One camera of the hull at a step: where it stands, what it sees, its depth range.
#[derive(Clone, Debug)]
pub struct HullView<'a> {
    /// The camera at the step (its working size: the frame's and plate's).
    pub camera: Camera,
    /// The step's frame.
    pub frame: &'a image::RgbImage,
    /// Its foreground at the step.
    pub foreground: Foreground,
    /// The median depth (m) of the static scene in the camera: rays start at
    /// [`HullOptions::near_fraction`] of it.
    pub median_static_depth_m: f64,
    /// The farthest depth (m) a ray is sampled to: the far static scene.
    pub far_depth_m: f64,
}

/// The median and the 95th percentile of the depths of `static_points` in `camera` (those in
/// its image); `None` with fewer than 16 of them.
pub fn static_depths(camera: &Camera, static_points: &PointCloud) -> Option<(f64, f64)> {
    let mut depths: Vec<f64> = static_points
        .positions_world
        .iter()
        .filter_map(|p| camera.project_world(glam::DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))))
        .filter(|(px, z)| *z > 0.0 && camera.contains(*px))
        .map(|(_, z)| z)
        .collect();
    depth_range(&mut depths)
}

/// The median and the 95th percentile of `depths_m` (sorted in place): a camera's depth range
/// for the hull; `None` with fewer than 16 of them.
pub fn depth_range(depths_m: &mut [f64]) -> Option<(f64, f64)> {
    if depths_m.len() < 16 {
        return None;
    }
    depths_m.sort_by(f64::total_cmp);
    Some((depths_m[depths_m.len() / 2], depths_m[depths_m.len() * 95 / 100]))
}

/// The hull's front points seen from every view of `views` (see the module's comment), less
/// those the step's `own` points stand for; an error only where OpenCV fails on a foreground.
pub fn hull_points(views: &[HullView], own: &PointCloud, options: &HullOptions) -> SfmResult<PointCloud> {
    let per_view: Vec<PointCloud> =
        (0..views.len()).into_par_iter().map(|c| view_points(views, c, own, options)).collect::<SfmResult<_>>()?;
    let mut out = PointCloud::default();
    for cloud in per_view {
        out.positions_world.extend(cloud.positions_world);
        out.colors.extend(cloud.colors);
    }
    Ok(out)
}

/// The hull's front points on the rays of view `c`.
fn view_points(views: &[HullView], c: usize, own: &PointCloud, options: &HullOptions) -> SfmResult<PointCloud> {
    let view = &views[c];
    let camera = &view.camera;
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let stride = (camera.width_px / options.rays_across).max(1) as usize;
    let near = options.near_fraction * view.median_static_depth_m;
    let far = view.far_depth_m.max(near * 1.01);
    let own_cells = OwnCells::of(camera, own, stride);
    // The own points that may carry a hull point: those on this view's foreground.
    let foreground_cells = (options.own_point_reach > 0).then(|| own_cells.on(&view.foreground.mask, camera));
    let strides = region_strides(&view.foreground.mask, stride, options.min_region_rays)?;
    let mut out = PointCloud::default();
    for y in 0..h {
        for x in 0..w {
            // A ray on the grid of its region's stride (0 off the foreground).
            let s = usize::from(strides[y * w + x]);
            if s == 0 || x % s != s / 2 || y % s != s / 2 {
                continue;
            }
            let pixel = DVec2::new(x as f64, y as f64);
            let Some(entry) = entry_depth(views, c, pixel, near, far, options) else { continue };
            if own_cells.at(x, y).iter().any(|&(_, d)| d >= entry * 0.95 && d <= entry * (1.0 + options.own_point_band)) {
                continue;
            }
            let depth = match &foreground_cells {
                None => entry,
                Some(cells) => surface_depth(views, c, pixel, entry, far, cells, options),
            };
            let p = camera.unproject_world(pixel, depth);
            out.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
            out.colors.push(view.frame.get_pixel(x as u32, y as u32).0);
        }
    }
    Ok(out)
}

/// Per pixel of `mask` (0/1, row-major), the stride of the ray grid its connected
/// (4-neighbour) foreground region is sampled on: `base`, or finer where that gives the region
/// fewer than `min_rays` rays (down to 1, every pixel); 0 off the foreground.
fn region_strides(mask: &ScalarRaster, base: usize, min_rays: usize) -> SfmResult<Vec<u16>> {
    let base = base.clamp(1, usize::from(u16::MAX));
    let on = |m: f32| m >= 0.5;
    if min_rays == 0 {
        return Ok(mask.data.iter().map(|&m| if on(m) { base as u16 } else { 0 }).collect());
    }
    let bytes: Vec<u8> = mask.data.iter().map(|&m| u8::from(on(m))).collect();
    let image = Mat::new_rows_cols_with_data(mask.height as i32, mask.width as i32, &bytes)
        .and_then(|m| m.try_clone())
        .map_err(SfmError::cv("foreground mask"))?;
    let (mut labels, mut stats, mut centroids) = (Mat::default(), Mat::default(), Mat::default());
    imgproc::connected_components_with_stats(&image, &mut labels, &mut stats, &mut centroids, 4, CV_32S)
        .map_err(SfmError::cv("foreground regions"))?;
    // Label 0 is the background.
    let stride_of = (0..stats.rows())
        .map(|label| {
            let area = *stats.at_2d::<i32>(label, imgproc::CC_STAT_AREA)? as usize;
            let stride = if label == 0 {
                0
            } else if area >= min_rays * base * base {
                base
            } else {
                ((area / min_rays) as f64).sqrt().floor().max(1.0) as usize
            };
            Ok(stride.min(base) as u16)
        })
        .collect::<Result<Vec<u16>, opencv::Error>>()
        .map_err(SfmError::cv("foreground region areas"))?;
    let labels = labels.data_typed::<i32>().map_err(SfmError::cv("foreground labels"))?;
    Ok(labels.iter().map(|&l| stride_of[l as usize]).collect())
}

/// The step's own points binned by the cells of one camera's ray grid: per cell of `stride` px,
/// the pixel and depth (m) of each point in it.
struct OwnCells {
    stride: usize,
    cells_x: usize,
    cells: Vec<Vec<(DVec2, f64)>>,
}

impl OwnCells {
    /// The points of `own` in front of `camera` and inside its image.
    fn of(camera: &Camera, own: &PointCloud, stride: usize) -> Self {
        let (cells_x, cells_y) = ((camera.width_px as usize).div_ceil(stride), (camera.height_px as usize).div_ceil(stride));
        let mut cells = vec![Vec::new(); cells_x * cells_y];
        for p in &own.positions_world {
            let Some((px, z)) = camera.project_world(glam::DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))) else { continue };
            if z > 0.0 && camera.contains(px) {
                let (x, y) = nearest_pixel(camera, px);
                cells[(y / stride) * cells_x + x / stride].push((px, z));
            }
        }
        Self { stride, cells_x, cells }
    }

    /// The same cells, each with only its points on `mask` (0/1, `camera`'s size).
    fn on(&self, mask: &ScalarRaster, camera: &Camera) -> Self {
        let on_mask = |px: DVec2| {
            let (x, y) = nearest_pixel(camera, px);
            mask.get(x, y) >= 0.5
        };
        let cells = self.cells.iter().map(|cell| cell.iter().copied().filter(|&(px, _)| on_mask(px)).collect()).collect();
        Self { stride: self.stride, cells_x: self.cells_x, cells }
    }

    /// The points of the cell holding pixel `(x, y)`.
    fn at(&self, x: usize, y: usize) -> &[(DVec2, f64)] {
        &self.cells[(y / self.stride) * self.cells_x + x / self.stride]
    }

    /// Cells down the image.
    fn cells_y(&self) -> usize {
        self.cells.len() / self.cells_x.max(1)
    }
}

/// The pixel of `camera`'s image nearest to `px` (a point inside it: [`Camera::contains`]).
fn nearest_pixel(camera: &Camera, px: DVec2) -> (usize, usize) {
    let clamp = |v: f64, size: u32| (v.round().max(0.0) as usize).min(size as usize - 1);
    (clamp(px.x, camera.width_px), clamp(px.y, camera.height_px))
}

/// Where the ray of view `c` through `pixel` enters the hull between `near` and `far` (z-depth,
/// m); `None` where it does not, or is inside already at `near` (nothing bounds it there).
fn entry_depth(views: &[HullView], c: usize, pixel: DVec2, near: f64, far: f64, options: &HullOptions) -> Option<f64> {
    match crossing(views, c, pixel, (near, far), 0, true, options)? {
        (0, _) => None,
        (_, depth) => Some(depth),
    }
}

/// Where the ray of view `c` through `pixel`, inside the hull at `entry`, leaves it before
/// `far` (sampled and refined as [`entry_depth`]); `far` where it does not.
fn exit_depth(views: &[HullView], c: usize, pixel: DVec2, entry: f64, far: f64, options: &HullOptions) -> f64 {
    crossing(views, c, pixel, (entry, far), 1, false, options).map_or(far, |(_, depth)| depth)
}

/// The first of [`HullOptions::depth_samples`] samples of the ray of view `c` through `pixel`
/// (evenly in inverse depth over `(from, to)`, from sample `first` on) that is inside the hull
/// when `inside` (outside when not), and the depth on the inside side of that crossing after
/// [`HullOptions::refine_steps`] bisections with the sample before it; `None` where no sample is.
fn crossing(
    views: &[HullView],
    c: usize,
    pixel: DVec2,
    (from, to): (f64, f64),
    first: usize,
    inside: bool,
    options: &HullOptions,
) -> Option<(usize, f64)> {
    let camera = &views[c].camera;
    let n = options.depth_samples;
    let depth_at = |s: f64| 1.0 / (1.0 / from + s * (1.0 / to - 1.0 / from));
    let is_in = |depth: f64| is_inside(views, c, camera.unproject_world(pixel, depth), options);
    let found = (first..n).find(|&i| is_in(depth_at(i as f64 / (n - 1) as f64)) == inside)?;
    if found == 0 {
        return Some((0, depth_at(0.0)));
    }
    // The sides of the crossing inside and outside the hull.
    let (before, at) = ((found - 1) as f64 / (n - 1) as f64, found as f64 / (n - 1) as f64);
    let (mut inner, mut outer) = if inside { (at, before) } else { (before, at) };
    for _ in 0..options.refine_steps {
        let mid = 0.5 * (inner + outer);
        if is_in(depth_at(mid)) {
            inner = mid;
        } else {
            outer = mid;
        }
    }
    Some((found, depth_at(inner)))
}

/// Where the ray of view `c` through `pixel`, entering the hull at `entry`, meets the surface
/// the own points around it give ([`HullOptions::own_point_reach`]): in each cell within the
/// reach (`cells`: the own points on the view's foreground), the nearest point that lies inside
/// the hull's depth interval on this ray; their depths weighted by
/// `1 / (1 + (distance / stride)^2)`, clamped to the interval. `entry` where no cell has one.
fn surface_depth(views: &[HullView], c: usize, pixel: DVec2, entry: f64, far: f64, cells: &OwnCells, options: &HullOptions) -> f64 {
    let (reach, stride) = (options.own_point_reach, cells.stride);
    let (cx, cy) = (pixel.x as usize / stride, pixel.y as usize / stride);
    // Per cell, its nearest point behind the entry.
    let mut nearest: Vec<(DVec2, f64)> = Vec::new();
    for y in cy.saturating_sub(reach)..(cy + reach + 1).min(cells.cells_y()) {
        for x in cx.saturating_sub(reach)..(cx + reach + 1).min(cells.cells_x) {
            let best = cells.cells[y * cells.cells_x + x].iter().filter(|(_, d)| *d >= entry * 0.97).min_by(|a, b| a.1.total_cmp(&b.1));
            nearest.extend(best);
        }
    }
    if nearest.is_empty() {
        return entry;
    }
    // At least `entry`: a ray that leaves at once gives it back, up to rounding.
    let exit = exit_depth(views, c, pixel, entry, far, options).max(entry);
    let (mut sum, mut weights) = (0.0, 0.0);
    for (px, d) in nearest.into_iter().filter(|(_, d)| *d <= exit * 1.03) {
        let w = 1.0 / (1.0 + (px - pixel).length_squared() / (stride * stride) as f64);
        sum += w * d;
        weights += w;
    }
    if weights == 0.0 { entry } else { (sum / weights).clamp(entry, exit) }
}

/// Whether `point` is inside the hull as the views other than `c` see it.
fn is_inside(views: &[HullView], c: usize, point: glam::DVec3, options: &HullOptions) -> bool {
    let (mut witnesses, mut background) = (0, 0);
    for (k, view) in views.iter().enumerate() {
        if k == c {
            continue;
        }
        let Some((px, z)) = view.camera.project_world(point) else { continue };
        if z <= 0.0 || !view.camera.contains(px) {
            continue;
        }
        let (x, y) = nearest_pixel(&view.camera, px);
        if view.foreground.keeps.get(x, y) < 0.5 {
            background += 1;
            if background > options.max_background_votes {
                return false;
            }
            continue;
        }
        if view.foreground.unknown.get(x, y) < 0.5 {
            witnesses += 1;
        }
    }
    witnesses >= options.min_witnesses
}

#[cfg(test)]
mod tests;
