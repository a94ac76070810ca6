//! Backward warps of the input frames into the novel view, and visibility `sigma_vis` by
//! scattering the novel pixels into per-input depth buffers (METHOD.md, "Warps, visibility").

use super::transfer::PixelTransfer;
use crate::camera::Camera;
use crate::par;
use crate::raster::{Rgb, RgbRaster, ScalarRaster};

/// Marks a novel pixel that does not land inside the input image.
const OUTSIDE: u32 = u32::MAX;

/// One input view warped into the novel view with the current depth.
#[derive(Clone, Debug)]
pub struct ViewWarp {
    /// `I^proj_s`: the input's color at each novel pixel (black where invalid).
    pub color: Vec<Rgb>,
    /// Index of the input pixel each novel pixel lands on (nearest), `u32::MAX` when outside.
    target: Vec<u32>,
    /// Depth of each novel pixel in the input camera.
    depth_in_input: Vec<f32>,
    /// `sigma_vis^s`: 1 where the novel pixel is the nearest one landing on its input pixel.
    pub visibility: Vec<f32>,
}

impl ViewWarp {
    /// True where the novel pixel lands inside the input image.
    #[inline]
    pub fn valid(&self, i: usize) -> bool {
        self.target[i] != OUTSIDE
    }
}

/// One row of the three outputs of a warp.
type WarpRow<'a> = (&'a mut [Rgb], (&'a mut [u32], &'a mut [f32]));

/// Backward-warps `input` (seen by `input_camera`) into `novel` with z-depth `depth`. The
/// visibility is left at 0; [`compute_visibility`] fills it.
pub fn warp_view(novel: &Camera, depth: &ScalarRaster, input_camera: &Camera, input: &RgbRaster) -> ViewWarp {
    let (w, h) = (depth.width, depth.height);
    let transfer = PixelTransfer::new(novel, input_camera);
    let n = w * h;
    let mut color = vec![[0.0f32; 3]; n];
    let mut target = vec![OUTSIDE; n];
    let mut depth_in_input = vec![0.0f32; n];
    let mut rows: Vec<WarpRow> = color.chunks_mut(w).zip(target.chunks_mut(w).zip(depth_in_input.chunks_mut(w))).collect();
    let work = |y: usize, (c_row, (t_row, d_row)): &mut WarpRow| {
        warp_row(&transfer, &depth.data[y * w..(y + 1) * w], y as f32, input, c_row, t_row, d_row);
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        rows.par_iter_mut().enumerate().for_each(|(y, row)| work(y, row));
    }
    #[cfg(not(feature = "parallel"))]
    rows.iter_mut().enumerate().for_each(|(y, row)| work(y, row));
    drop(rows);
    ViewWarp { color, target, depth_in_input, visibility: vec![0.0; n] }
}

/// One row of [`warp_view`]: transfer, bilinear sample (edge pixels clamped), nearest input
/// pixel and depth in the input camera.
fn warp_row(
    transfer: &PixelTransfer,
    depth_row: &[f32],
    y: f32,
    input: &RgbRaster,
    c_row: &mut [Rgb],
    t_row: &mut [u32],
    d_row: &mut [f32],
) {
    let (iw, ih) = (input.width, input.height);
    let (wf, hf) = (iw as f32, ih as f32);
    let data = &input.data;
    let row = transfer.row(y);
    for (x, &d) in depth_row.iter().enumerate() {
        if !(d > 0.0 && d < f32::INFINITY) {
            continue;
        }
        let Some((u, v, z)) = row.apply(x as f32, d) else { continue };
        if !(u >= -0.5 && v >= -0.5 && u < wf - 0.5 && v < hf - 0.5) {
            continue;
        }
        let uc = u.clamp(0.0, wf - 1.0);
        let vc = v.clamp(0.0, hf - 1.0);
        let (x0, y0) = (uc as usize, vc as usize);
        let (fx, fy) = (uc - x0 as f32, vc - y0 as f32);
        let dx = usize::from(x0 + 1 < iw);
        let dy = if y0 + 1 < ih { iw } else { 0 };
        let i00 = y0 * iw + x0;
        let (a, b, c, e) = (data[i00], data[i00 + dx], data[i00 + dy], data[i00 + dy + dx]);
        let mut out = [0.0f32; 3];
        for k in 0..3 {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (e[k] - c[k]) * fx;
            out[k] = top + (bottom - top) * fy;
        }
        c_row[x] = out;
        let (ui, vi) = ((u + 0.5) as usize, (v + 0.5) as usize);
        t_row[x] = (vi.min(ih - 1) * iw + ui.min(iw - 1)) as u32;
        d_row[x] = z;
    }
}

/// Fills `warp.visibility`: scatter every valid novel pixel's depth into a depth buffer the
/// size of the input image with a min, then keep the pixels within `tolerance` (relative) of
/// that minimum.
pub fn compute_visibility(warp: &mut ViewWarp, input_pixels: usize, tolerance: f32) {
    let mut zbuf = vec![f32::INFINITY; input_pixels];
    for (&t, &z) in warp.target.iter().zip(&warp.depth_in_input) {
        if t != OUTSIDE {
            let slot = &mut zbuf[t as usize];
            if z < *slot {
                *slot = z;
            }
        }
    }
    let ViewWarp { target, depth_in_input, visibility, .. } = warp;
    const CHUNK: usize = 4096;
    par::for_each_row_mut(visibility, CHUNK, |chunk, out| {
        let start = chunk * CHUNK;
        for (k, v) in out.iter_mut().enumerate() {
            let i = start + k;
            let t = target[i];
            *v = if t != OUTSIDE && depth_in_input[i] <= zbuf[t as usize] * (1.0 + tolerance) { 1.0 } else { 0.0 };
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Rigid3};
    use glam::DVec3;

    fn cam(eye: DVec3, w: u32, h: u32) -> Camera {
        Camera {
            intrinsics: Intrinsics::from_vertical_fov(0.9, w, h),
            camera_from_world: Rigid3::camera_from_world_looking_at(eye, DVec3::ZERO, DVec3::Y),
            width_px: w,
            height_px: h,
        }
    }

    #[test]
    fn warp_from_the_same_camera_reproduces_the_input() {
        let c = cam(DVec3::new(0.0, 0.0, 4.0), 16, 12);
        let input = RgbRaster::from_vec(16, 12, (0..192).map(|i| [(i % 16) as f32 / 16.0, (i / 16) as f32 / 12.0, 0.5]).collect()).unwrap();
        let depth = ScalarRaster::filled(16, 12, 3.0);
        let mut warp = warp_view(&c, &depth, &c, &input);
        compute_visibility(&mut warp, 192, 0.01);
        for i in 0..192 {
            assert!(warp.valid(i));
            for k in 0..3 {
                assert!((warp.color[i][k] - input.data[i][k]).abs() < 1e-4);
            }
            assert_eq!(warp.visibility[i], 1.0);
        }
    }

    #[test]
    fn occluded_pixels_get_zero_visibility() {
        // Fronto-parallel: a near square (depth 2) in front of a far plane (depth 6). The input
        // camera sits 1 m to the right, so the square shifts left by about 10 px and the far
        // plane by about 3.5 px: far pixels just left of the square are hidden in the input.
        let novel = Camera {
            intrinsics: Intrinsics::from_vertical_fov(0.9, 40, 20),
            camera_from_world: Rigid3::IDENTITY,
            width_px: 40,
            height_px: 20,
        };
        let mut input = novel;
        input.camera_from_world.translation = DVec3::new(-1.0, 0.0, 0.0);
        let image = RgbRaster::filled(40, 20, [0.5; 3]);
        let near = |x: usize, y: usize| (15..25).contains(&x) && (5..15).contains(&y);
        let depth = ScalarRaster::from_vec(40, 20, (0..800).map(|i| if near(i % 40, i / 40) { 2.0 } else { 6.0 }).collect()).unwrap();
        let mut warp = warp_view(&novel, &depth, &input, &image);
        compute_visibility(&mut warp, 800, 0.02);
        let at = |x: usize| 10 * 40 + x;
        assert!((15..25).all(|x| warp.visibility[at(x)] == 1.0), "near square must be visible");
        assert!((10..14).all(|x| warp.valid(at(x)) && warp.visibility[at(x)] == 0.0), "far pixels behind the square must be hidden");
        assert!((28..36).all(|x| warp.visibility[at(x)] == 1.0), "far pixels in the open must be visible");
    }
}
