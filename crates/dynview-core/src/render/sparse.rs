//! Z-buffered splatting: the sparse depth and color maps of a point cloud (nearest point per
//! pixel wins), and the previous output frame forward-warped into the current camera.

use super::transfer::PixelTransfer;
use crate::camera::Camera;
use crate::points::PointCloud;
use crate::raster::{Raster, Rgb, RgbRaster, ScalarRaster, unit_from_u8};

/// Splatted depth and color with a coverage mask.
#[derive(Clone, Debug)]
pub struct SplatMaps {
    /// z-depth of the nearest sample per pixel; `f32::INFINITY` where none landed.
    pub depth: ScalarRaster,
    /// Color of that sample.
    pub color: RgbRaster,
    /// 1 where a sample landed, 0 elsewhere (`m(x)` of METHOD.md).
    pub mask: ScalarRaster,
}

impl SplatMaps {
    fn empty(width: usize, height: usize) -> Self {
        Self {
            depth: Raster::filled(width, height, f32::INFINITY),
            color: Raster::filled(width, height, [0.0; 3]),
            mask: Raster::filled(width, height, 0.0),
        }
    }

    #[inline]
    fn splat(&mut self, u: f32, v: f32, depth: f32, color: Rgb) {
        let Some(i) = pixel_index(u, v, self.depth.width, self.depth.height) else { return };
        if depth < self.depth.data[i] {
            self.depth.data[i] = depth;
            self.color.data[i] = color;
            self.mask.data[i] = 1.0;
        }
    }

    /// Number of covered pixels.
    pub fn covered(&self) -> usize {
        self.mask.data.iter().filter(|&&m| m > 0.0).count()
    }
}

impl SplatMaps {
    /// Every sample attached over its footprint: a pixel without a sample takes the nearest one
    /// (smallest depth; the first in row-major order among equals) within `radius` pixels, so
    /// that the depth energy attaches to a patch around each point rather than one pixel (see
    /// `RenderParams::sparse_footprint_px`). The GPU's `splat_footprint.wgsl` does the same.
    pub fn with_footprint(&self, radius: usize) -> SplatMaps {
        let (w, h) = (self.mask.width, self.mask.height);
        let mut out = self.clone();
        if radius == 0 {
            return out;
        }
        // Scatter each sample over its window (samples are few): visiting them in row-major
        // order and replacing only on a strictly smaller depth keeps, for every pixel, the
        // nearest sample and the first among equals, as a gather over the window would.
        let mut best: Vec<u32> = vec![u32::MAX; w * h];
        for j in (0..w * h).filter(|&j| self.mask.data[j] > 0.0) {
            let (x, y) = (j % w, j / w);
            let depth = self.depth.data[j];
            for yy in y.saturating_sub(radius)..=(y + radius).min(h - 1) {
                let row = yy * w + x.saturating_sub(radius)..=yy * w + (x + radius).min(w - 1);
                for (slot, &m) in best[row.clone()].iter_mut().zip(&self.mask.data[row]) {
                    if m <= 0.0 && (*slot == u32::MAX || depth < self.depth.data[*slot as usize]) {
                        *slot = j as u32;
                    }
                }
            }
        }
        for (i, &j) in best.iter().enumerate().filter(|(_, j)| **j != u32::MAX) {
            let j = j as usize;
            out.depth.data[i] = self.depth.data[j];
            out.color.data[i] = self.color.data[j];
            out.mask.data[i] = 1.0;
        }
        out
    }

    /// Removes samples that cannot be right in this view, in two passes over a window of
    /// `radius` pixels (`None`: half the mean spacing between samples, 1 to 8 pixels):
    ///
    /// 1. isolated front samples: no other sample in the window (nor, with the surround test,
    ///    within `surround_px` pixels) lies within `ratio` of its depth and at least two in the
    ///    window lie clearly behind it (an outlier floating in front);
    /// 2. occluded samples: a remaining sample in the window is nearer by more than the factor
    ///    `1 + ratio` (a point some input camera saw but this view cannot: a sparse cloud has
    ///    no surfaces to hide it in a z-buffer), or, within `surround_px` pixels (0: no such
    ///    test), samples nearer by that factor lie in each of its four quadrants (it is inside
    ///    a nearer surface sparser than the window reaches across; see [`super::surround`]).
    ///
    /// Returns the number of samples removed.
    pub fn drop_inconsistent(&mut self, ratio: f32, radius: Option<usize>, surround_px: usize) -> usize {
        let (w, h) = (self.depth.width, self.depth.height);
        let covered = self.covered();
        if covered == 0 {
            return 0;
        }
        let spacing = ((w * h) as f32 / covered as f32).sqrt();
        let r = radius.unwrap_or_else(|| (0.5 * spacing).ceil().clamp(1.0, 8.0) as usize);
        let samples: Vec<usize> = (0..w * h).filter(|&i| self.mask.data[i] > 0.0).collect();
        let square = |i: usize, radius: usize| {
            let (x, y) = (i % w, i / w);
            let (x0, x1) = (x.saturating_sub(radius), (x + radius).min(w - 1));
            let (y0, y1) = (y.saturating_sub(radius), (y + radius).min(h - 1));
            (y0..=y1).flat_map(move |yy| (x0..=x1).map(move |xx| yy * w + xx)).filter(move |&j| j != i)
        };
        let window = |i: usize| square(i, r);
        let mut remove = Vec::new();
        for &i in &samples {
            let d = self.depth.data[i];
            let (mut support, mut behind) = (0, 0);
            for j in window(i) {
                if self.mask.data[j] > 0.0 {
                    let dj = self.depth.data[j];
                    if (dj - d).abs() <= ratio * d {
                        support += 1;
                    } else if dj > d * (1.0 + ratio) {
                        behind += 1;
                    }
                }
            }
            // A sample of a sparse surface in front of a dense one has no neighbour of its own
            // within the small window: look for one as far as the surround test reaches.
            if support == 0
                && behind >= 2
                && !(surround_px > r
                    && square(i, surround_px).any(|j| self.mask.data[j] > 0.0 && (self.depth.data[j] - d).abs() <= ratio * d))
            {
                remove.push(i);
            }
        }
        for &i in &remove {
            self.mask.data[i] = 0.0;
        }
        let quadrants = (surround_px > 0).then(|| {
            let front: Vec<f32> =
                self.depth.data.iter().zip(&self.mask.data).map(|(&d, &m)| if m > 0.0 { d } else { f32::INFINITY }).collect();
            super::surround::quadrant_minima(&front, w, h, surround_px)
        });
        let surrounded = |i: usize, d: f32| quadrants.as_ref().is_some_and(|q| q.iter().all(|q| d > q[i] * (1.0 + ratio)));
        let mut occluded = Vec::new();
        for &i in &samples {
            if self.mask.data[i] <= 0.0 {
                continue;
            }
            let d = self.depth.data[i];
            if surrounded(i, d) || window(i).any(|j| self.mask.data[j] > 0.0 && d > self.depth.data[j] * (1.0 + ratio)) {
                occluded.push(i);
            }
        }
        for &i in remove.iter().chain(&occluded) {
            self.mask.data[i] = 0.0;
            self.depth.data[i] = f32::INFINITY;
        }
        remove.len() + occluded.len()
    }
}

/// The pixel (row-major index) that a sample at `(u, v)` lands on in a `width x height` image:
/// the nearest pixel centre; `None` outside the image (or for a NaN position).
#[inline]
fn pixel_index(u: f32, v: f32, width: usize, height: usize) -> Option<usize> {
    let (x, y) = (u.round(), v.round());
    (x >= 0.0 && y >= 0.0 && x < width as f32 && y < height as f32).then(|| y as usize * width + x as usize)
}

/// Calls `visit(i, u, v, depth)` for each point `i` of `positions_world` in front of `camera`,
/// with its pixel position (not rounded) and z-depth.
#[inline]
fn for_each_projected(positions_world: &[[f32; 3]], camera: &Camera, mut visit: impl FnMut(usize, f32, f32, f32)) {
    let r = camera.camera_from_world.rotation;
    let t = camera.camera_from_world.translation;
    let k = camera.intrinsics;
    // f32 per point: precision far below a pixel for scenes of tens of metres.
    let rows: [[f32; 4]; 3] = std::array::from_fn(|i| {
        let row = r.row(i);
        [row.x as f32, row.y as f32, row.z as f32, t[i] as f32]
    });
    let (fx, fy, cx, cy) = (k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32);
    for (i, p) in positions_world.iter().enumerate() {
        let xc = rows[0][0] * p[0] + rows[0][1] * p[1] + rows[0][2] * p[2] + rows[0][3];
        let yc = rows[1][0] * p[0] + rows[1][1] * p[1] + rows[1][2] * p[2] + rows[1][3];
        let zc = rows[2][0] * p[0] + rows[2][1] * p[1] + rows[2][2] * p[2] + rows[2][3];
        if zc <= 1e-6 {
            continue;
        }
        visit(i, fx * xc / zc + cx, fy * yc / zc + cy, zc);
    }
}

/// Projects `cloud` into `camera` (`D^`, `I^` and `m` of METHOD.md).
pub fn project_cloud(cloud: &PointCloud, camera: &Camera) -> SplatMaps {
    let mut maps = SplatMaps::empty(camera.width_px as usize, camera.height_px as usize);
    for_each_projected(&cloud.positions_world, camera, |i, u, v, z| maps.splat(u, v, z, cloud.colors[i].map(unit_from_u8)));
    maps
}

/// The z-depth of the nearest of `positions_world` at each pixel of `camera`, infinite where
/// none lands: [`project_cloud`]'s depth without the colours.
pub fn nearest_depth(positions_world: &[[f32; 3]], camera: &Camera) -> ScalarRaster {
    let (width, height) = (camera.width_px as usize, camera.height_px as usize);
    let mut depth = Raster::filled(width, height, f32::INFINITY);
    for_each_projected(positions_world, camera, |_, u, v, z| {
        if let Some(i) = pixel_index(u, v, width, height)
            && z < depth.data[i]
        {
            depth.data[i] = z;
        }
    });
    depth
}

/// Forward-warps a rendered frame (its camera, depth and color) into `camera`: the
/// `D_{t-1}^{proj}` and `I_{t-1}^{proj}` of the temporal terms, with coverage as validity.
pub fn warp_frame(source: &Camera, depth: &ScalarRaster, color: &RgbRaster, camera: &Camera) -> SplatMaps {
    let mut maps = SplatMaps::empty(camera.width_px as usize, camera.height_px as usize);
    let transfer = PixelTransfer::new(source, camera);
    for y in 0..depth.height {
        for x in 0..depth.width {
            let d = depth.get(x, y);
            if !(d.is_finite() && d > 0.0) {
                continue;
            }
            if let Some((u, v, z)) = transfer.apply(x as f32, y as f32, d) {
                maps.splat(u, v, z, color.get(x, y));
            }
        }
    }
    maps
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Rigid3};
    use glam::DVec3;

    fn camera() -> Camera {
        Camera {
            intrinsics: Intrinsics { fx: 10.0, fy: 10.0, cx: 4.5, cy: 3.5 },
            camera_from_world: Rigid3::IDENTITY,
            width_px: 10,
            height_px: 8,
        }
    }

    #[test]
    fn nearest_point_wins() {
        let cloud = PointCloud {
            positions_world: vec![[0.0, 0.0, 3.0], [0.0, 0.0, 2.0], [0.0, 0.0, 4.0], [0.0, 0.0, -1.0], [5.0, 0.0, 1.0]],
            colors: vec![[255, 0, 0], [0, 255, 0], [0, 0, 255], [9, 9, 9], [9, 9, 9]],
        };
        let maps = project_cloud(&cloud, &camera());
        // (0, 0, z) lands at the principal point, rounded to pixel (5, 4) (4.5 rounds up).
        let centre = maps.depth.get(5, 4);
        assert_eq!(centre, 2.0);
        assert_eq!(maps.color.get(5, 4), [0.0, 1.0, 0.0]);
        assert_eq!(maps.covered(), 1); // behind-camera and off-image points are dropped
    }

    #[test]
    fn occluded_samples_are_dropped() {
        let mut maps = SplatMaps::empty(20, 20);
        // A near cluster (depth 2) with one far sample (depth 5) inside it; a far cluster
        // (depth 5) with one outlier floating in front (depth 3).
        for (x, y, d) in [(5, 5, 2.0), (7, 5, 2.0), (5, 7, 2.0), (7, 7, 2.0), (6, 6, 5.0)] {
            maps.splat(x as f32, y as f32, d, [0.5; 3]);
        }
        for (x, y, d) in [(14, 14, 5.0), (16, 14, 5.0), (14, 16, 5.0), (16, 16, 5.0), (15, 15, 3.0)] {
            maps.splat(x as f32, y as f32, d, [0.5; 3]);
        }
        let dropped = maps.drop_inconsistent(0.03, Some(2), 0);
        assert_eq!(dropped, 2);
        assert_eq!(maps.mask.get(6, 6), 0.0, "occluded far sample");
        assert_eq!(maps.mask.get(15, 15), 0.0, "floating outlier");
        assert_eq!(maps.mask.get(16, 16), 1.0);
        assert_eq!(maps.covered(), 8);
    }

    #[test]
    fn frame_warp_to_itself_is_identity() {
        let cam = camera();
        let depth = ScalarRaster::filled(10, 8, 2.0);
        let color = RgbRaster::from_vec(10, 8, (0..80).map(|i| [i as f32 / 80.0, 0.0, 0.0]).collect()).unwrap();
        let maps = warp_frame(&cam, &depth, &color, &cam);
        assert_eq!(maps.covered(), 80);
        assert_eq!(maps.color, color);
        // Moving the camera back 1 m: everything is 1 m further away.
        let mut back = cam;
        back.camera_from_world.translation = DVec3::new(0.0, 0.0, 1.0);
        let maps = warp_frame(&cam, &depth, &color, &back);
        assert!(maps.depth.data.iter().filter(|d| d.is_finite()).all(|&d| (d - 3.0).abs() < 1e-5));
    }

    #[test]
    fn a_footprint_lends_the_nearest_point_to_the_pixels_around_it() {
        let mut maps = SplatMaps::empty(7, 5);
        for (i, depth, color) in [(2 * 7 + 2, 3.0, [1.0, 0.0, 0.0]), (2 * 7 + 4, 2.0, [0.0, 1.0, 0.0])] {
            maps.depth.data[i] = depth;
            maps.color.data[i] = color;
            maps.mask.data[i] = 1.0;
        }
        assert_eq!(maps.with_footprint(0).mask.data, maps.mask.data);
        let wide = maps.with_footprint(1);
        // Between the two points the nearer (depth 2) wins; beside the far one it is its own.
        assert_eq!((wide.depth.get(3, 2), wide.color.get(3, 2)), (2.0, [0.0, 1.0, 0.0]));
        assert_eq!((wide.depth.get(1, 1), wide.color.get(1, 1)), (3.0, [1.0, 0.0, 0.0]));
        // The points themselves keep theirs; out of reach stays empty.
        assert_eq!(wide.depth.get(2, 2), 3.0);
        assert!(wide.mask.get(0, 0) == 0.0 && wide.depth.get(0, 0).is_infinite());
        assert_eq!(wide.covered(), 15);
    }
}
