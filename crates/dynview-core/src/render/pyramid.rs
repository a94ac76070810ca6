//! Image pyramids: 2x2 box downsampling, bilinear upsampling, level sizes and cameras.

use crate::camera::Camera;
use crate::raster::Raster;

/// Size of the next coarser level: `ceil(n / 2)`, at least 1.
pub fn half(n: usize) -> usize {
    n.div_ceil(2).max(1)
}

/// Sizes of `levels` levels starting from `width x height` (level 0 first).
pub fn level_sizes(width: usize, height: usize, levels: usize) -> Vec<(usize, usize)> {
    let mut sizes = vec![(width, height)];
    for _ in 1..levels {
        let (w, h) = sizes[sizes.len() - 1];
        sizes.push((half(w), half(h)));
    }
    sizes
}

/// The camera seeing the same view at another resolution.
pub fn camera_at(camera: &Camera, width: usize, height: usize) -> Camera {
    camera.resized(width as u32, height as u32)
}

/// The camera of a quick preview at pyramid `level`: `1 / 2^level` of the camera's size per
/// side (levels beyond 4 count as 4), at least 16x9 pixels; level 0 is the camera itself.
pub fn preview_camera(camera: &Camera, level: usize) -> Camera {
    if level == 0 {
        return *camera;
    }
    let shrink = 1usize << level.min(4);
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    camera_at(camera, w.div_ceil(shrink).max(16), h.div_ceil(shrink).max(9))
}

/// Values that can be averaged and interpolated.
pub trait Pixel: Copy + Send + Sync + Default {
    /// `self * s`.
    fn scale(self, s: f32) -> Self;
    /// `self + other`.
    fn add(self, other: Self) -> Self;
}

impl Pixel for f32 {
    #[inline]
    fn scale(self, s: f32) -> Self {
        self * s
    }
    #[inline]
    fn add(self, other: Self) -> Self {
        self + other
    }
}

impl Pixel for [f32; 3] {
    #[inline]
    fn scale(self, s: f32) -> Self {
        [self[0] * s, self[1] * s, self[2] * s]
    }
    #[inline]
    fn add(self, o: Self) -> Self {
        [self[0] + o[0], self[1] + o[1], self[2] + o[2]]
    }
}

/// 2x2 box downsampling (edge pixels of odd sizes average what exists).
pub fn downsample<T: Pixel>(image: &Raster<T>) -> Raster<T> {
    let (w, h) = (half(image.width), half(image.height));
    let mut out = Raster::filled(w, h, T::default());
    crate::par::for_each_row_mut(&mut out.data, w, |y, row| {
        let y0 = 2 * y;
        let y1 = (2 * y + 1).min(image.height - 1);
        for (x, px) in row.iter_mut().enumerate() {
            let x0 = 2 * x;
            let x1 = (2 * x + 1).min(image.width - 1);
            let sum = image.get(x0, y0).add(image.get(x1, y0)).add(image.get(x0, y1)).add(image.get(x1, y1));
            *px = sum.scale(0.25);
        }
    });
    out
}

/// Bilinear upsampling to `width x height` (pixel centres aligned as by `Camera::resized`).
pub fn upsample<T: Pixel>(image: &Raster<T>, width: usize, height: usize) -> Raster<T> {
    let sx = image.width as f32 / width as f32;
    let sy = image.height as f32 / height as f32;
    let mut out = Raster::filled(width, height, T::default());
    crate::par::for_each_row_mut(&mut out.data, width, |y, row| {
        let fy = ((y as f32 + 0.5) * sy - 0.5).clamp(0.0, (image.height - 1) as f32);
        let y0 = fy.floor() as usize;
        let y1 = (y0 + 1).min(image.height - 1);
        let ty = fy - y0 as f32;
        for (x, px) in row.iter_mut().enumerate() {
            let fx = ((x as f32 + 0.5) * sx - 0.5).clamp(0.0, (image.width - 1) as f32);
            let x0 = fx.floor() as usize;
            let x1 = (x0 + 1).min(image.width - 1);
            let tx = fx - x0 as f32;
            let top = image.get(x0, y0).scale(1.0 - tx).add(image.get(x1, y0).scale(tx));
            let bottom = image.get(x0, y1).scale(1.0 - tx).add(image.get(x1, y1).scale(tx));
            *px = top.scale(1.0 - ty).add(bottom.scale(ty));
        }
    });
    out
}

/// Levels of an image, finest first.
pub fn build<T: Pixel>(image: Raster<T>, levels: usize) -> Vec<Raster<T>> {
    let mut out = vec![image];
    for _ in 1..levels {
        let next = downsample(&out[out.len() - 1]);
        out.push(next);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::ScalarRaster;

    #[test]
    fn sizes_and_box_filter() {
        assert_eq!(level_sizes(960, 540, 4), vec![(960, 540), (480, 270), (240, 135), (120, 68)]);
        let img = ScalarRaster::from_vec(3, 2, vec![1.0, 2.0, 3.0, 5.0, 6.0, 7.0]).unwrap();
        let d = downsample(&img);
        assert_eq!((d.width, d.height), (2, 1));
        assert_eq!(d.data, vec![3.5, 5.0]);
    }

    #[test]
    fn upsample_of_constant_and_ramp() {
        let c = ScalarRaster::filled(3, 2, 4.0);
        assert!(upsample(&c, 6, 4).data.iter().all(|&v| (v - 4.0).abs() < 1e-6));
        // A linear ramp stays linear in the interior.
        let ramp = ScalarRaster::from_vec(4, 1, vec![0.0, 2.0, 4.0, 6.0]).unwrap();
        let up = upsample(&ramp, 8, 1);
        for x in 1..7 {
            assert!((up.data[x] - (x as f32 - 0.5)).abs() < 1e-5, "{:?}", up.data);
        }
    }
}
