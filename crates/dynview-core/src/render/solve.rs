//! The two quadratic energies of METHOD.md on the pixel grid, their linear systems, and a
//! red-black over-relaxed Gauss-Seidel solver.
//!
//! Each 4-neighbour edge is counted once (METHOD.md writes `sum_x sum_{y in N(x)}`, which counts
//! it twice; counting it once gives exactly METHOD.md's closed-form update). An edge's weight is
//! the mean of its two pixels' weights. Setting the gradient of an energy to zero gives
//! `diag_x u_x - sum_y a_xy u_y = rhs_x` per pixel: a screened Poisson equation.

use super::pyramid::Pixel;
use super::warp::ViewWarp;
use crate::par;
use crate::raster::Rgb;

/// A linear system on a `width x height` grid with 4-neighbour couplings.
#[derive(Clone, Debug)]
pub struct GridSystem<T> {
    /// Grid width.
    pub width: usize,
    /// Grid height.
    pub height: usize,
    /// Coupling of pixel `i` with `i + 1` (0 in the last column).
    pub right: Vec<f32>,
    /// Coupling of pixel `i` with `i + width` (0 in the last row).
    pub down: Vec<f32>,
    /// `1 / diag_i`.
    pub inv_diag: Vec<f32>,
    /// Right-hand side.
    pub rhs: Vec<T>,
}

impl<T: Pixel> GridSystem<T> {
    #[inline]
    fn neighbour_sum(&self, u: &[T], i: usize, x: usize, y: usize) -> T {
        let w = self.width;
        let mut acc = self.rhs[i];
        if x > 0 {
            acc = acc.add(u[i - 1].scale(self.right[i - 1]));
        }
        if x + 1 < w {
            acc = acc.add(u[i + 1].scale(self.right[i]));
        }
        if y > 0 {
            acc = acc.add(u[i - w].scale(self.down[i - w]));
        }
        if y + 1 < self.height {
            acc = acc.add(u[i + w].scale(self.down[i]));
        }
        acc
    }

    /// One red-black sweep with over-relaxation `omega`: all pixels with `(x + y)` even, then
    /// all odd ones. `scratch` must have the length of `u`.
    pub fn sweep(&self, u: &mut Vec<T>, scratch: &mut Vec<T>, omega: f32) {
        for parity in 0..2 {
            let src: &[T] = u;
            par::for_each_row_mut(scratch, self.width, |y, row| {
                let base = y * self.width;
                row.copy_from_slice(&src[base..base + self.width]);
                let mut x = (y + parity) & 1;
                while x < self.width {
                    let i = base + x;
                    let gs = self.neighbour_sum(src, i, x, y).scale(self.inv_diag[i]);
                    let old = src[i];
                    row[x] = old.add(gs.add(old.scale(-1.0)).scale(omega));
                    x += 2;
                }
            });
            std::mem::swap(u, scratch);
        }
    }

    /// Relative residual `||rhs - A u|| / ||rhs||` (Euclidean over all pixels and channels).
    pub fn relative_residual(&self, u: &[T]) -> f64
    where
        T: Norm,
    {
        let rows = self.height;
        let num = par::sum_rows(rows, |y| {
            let mut s = 0.0f64;
            for x in 0..self.width {
                let i = y * self.width + x;
                // diag u - sum a u - rhs = (u - (rhs + sum a u) / diag) * diag
                let gs = self.neighbour_sum(u, i, x, y).scale(self.inv_diag[i]);
                let r = u[i].add(gs.scale(-1.0)).scale(1.0 / self.inv_diag[i]);
                s += f64::from(r.norm_sq());
            }
            s
        });
        let den: f64 = self.rhs.iter().map(|b| f64::from(b.norm_sq())).sum();
        (num / den.max(1e-30)).sqrt()
    }
}

/// Squared Euclidean norm of a pixel value.
pub trait Norm {
    /// `||self||^2`.
    fn norm_sq(self) -> f32;
}

impl Norm for f32 {
    fn norm_sq(self) -> f32 {
        self * self
    }
}

impl Norm for Rgb {
    fn norm_sq(self) -> f32 {
        self[0] * self[0] + self[1] * self[1] + self[2] * self[2]
    }
}

/// The terms of the depth energy (paper Eqs. rendering_depth and depth_temporalconsistency):
///
/// `E_D = sum_edges w_D,xy (D_x - D_y)^2 + sum_x [ attach_x (D_x - D^_x)^2 + temporal_x (D_x - Dprev_x)^2
///        + lambda_plane (D_x - Dplane_x)^2 ]`
///
/// with `attach = lambda_PC w_H m` and `temporal = lambda_T w_T`; the last term is ours (see
/// [`super::plane`]).
#[derive(Clone, Debug)]
pub struct DepthTerms {
    /// Grid width.
    pub width: usize,
    /// Grid height.
    pub height: usize,
    /// `w_D` per pixel.
    pub w_d: Vec<f32>,
    /// `lambda_PC w_H(x) m(x)`.
    pub attach: Vec<f32>,
    /// `D^`: the sparse depth (ignored where `attach` is 0).
    pub sparse_depth: Vec<f32>,
    /// `lambda_T w_T(x)`.
    pub temporal: Vec<f32>,
    /// `D_{t-1}^{proj}` (ignored where `temporal` is 0).
    pub previous_depth: Vec<f32>,
    /// `lambda_plane (1 - support)`: the pull toward `plane_depth` per pixel (ours; empty = none).
    pub plane_weight: Vec<f32>,
    /// The depth of the fitted plane per pixel (ignored where `plane_weight` is 0 or empty).
    pub plane_depth: Vec<f32>,
}

#[inline]
fn finite_or_zero(v: f32) -> f32 {
    if v.is_finite() { v } else { 0.0 }
}

impl DepthTerms {
    /// The energy `E_D` at `depth`.
    pub fn energy(&self, depth: &[f32]) -> f64 {
        let w = self.width;
        par::sum_rows(self.height, |y| {
            let mut e = 0.0f64;
            for x in 0..w {
                let i = y * w + x;
                if x + 1 < w {
                    e += f64::from(0.5 * (self.w_d[i] + self.w_d[i + 1]) * (depth[i] - depth[i + 1]).powi(2));
                }
                if y + 1 < self.height {
                    e += f64::from(0.5 * (self.w_d[i] + self.w_d[i + w]) * (depth[i] - depth[i + w]).powi(2));
                }
                if self.attach[i] > 0.0 {
                    e += f64::from(self.attach[i] * (depth[i] - self.sparse_depth[i]).powi(2));
                }
                if let Some(&p) = self.plane_weight.get(i)
                    && p > 0.0
                {
                    e += f64::from(p * (depth[i] - self.plane_depth[i]).powi(2));
                }
                if self.temporal[i] > 0.0 {
                    e += f64::from(self.temporal[i] * (depth[i] - self.previous_depth[i]).powi(2));
                }
            }
            e
        })
    }

    /// The linear system whose solution minimises `E_D`.
    pub fn system(&self) -> GridSystem<f32> {
        let (w, h) = (self.width, self.height);
        let n = w * h;
        let mut right = vec![0.0f32; n];
        let mut down = vec![0.0f32; n];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if x + 1 < w {
                    right[i] = 0.5 * (self.w_d[i] + self.w_d[i + 1]);
                }
                if y + 1 < h {
                    down[i] = 0.5 * (self.w_d[i] + self.w_d[i + w]);
                }
            }
        }
        let mut inv_diag = vec![0.0f32; n];
        let mut rhs = vec![0.0f32; n];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let plane = self.plane_weight.get(i).copied().unwrap_or(0.0);
                let mut diag = self.attach[i] + self.temporal[i] + plane;
                diag += right[i] + down[i];
                if x > 0 {
                    diag += right[i - 1];
                }
                if y > 0 {
                    diag += down[i - w];
                }
                inv_diag[i] = if diag > 0.0 { 1.0 / diag } else { 0.0 };
                rhs[i] = self.attach[i] * finite_or_zero(self.sparse_depth[i]) + self.temporal[i] * finite_or_zero(self.previous_depth[i]);
                if plane > 0.0 {
                    rhs[i] += plane * finite_or_zero(self.plane_depth[i]);
                }
            }
        }
        GridSystem { width: w, height: h, right, down, inv_diag, rhs }
    }
}

/// One view's contribution to the color energy: its warp and its weight `w_P^s`.
#[derive(Clone, Copy, Debug)]
pub struct ColorView<'a> {
    /// The warped input `P^s = I^proj_s`.
    pub warp: &'a ViewWarp,
    /// `w_P^s` per pixel.
    pub w_p: &'a [f32],
}

impl ColorView<'_> {
    /// `w^s_xy`: mean of the endpoints' `w_P^s`, 0 when either warp is invalid.
    #[inline]
    fn edge_weight(&self, i: usize, j: usize) -> f32 {
        if self.warp.valid(i) && self.warp.valid(j) { 0.5 * (self.w_p[i] + self.w_p[j]) } else { 0.0 }
    }
}

/// The terms of the color energy (paper Eqs. rendering_color and color_temporalconsistency):
///
/// `E_I = sum_edges [ ||I_x - I_y||^2 + sum_s lambda_G w^s_xy ||(I_x - I_y) - (P^s_x - P^s_y)||^2 ]
///      + sum_x [ sum_s lambda_P w_P^s(x) ||I_x - P^s_x||^2 + temporal_x ||I_x - Iprev_x||^2 ]`
#[derive(Clone, Debug)]
pub struct ColorTerms<'a> {
    /// Grid width.
    pub width: usize,
    /// Grid height.
    pub height: usize,
    /// The views.
    pub views: Vec<ColorView<'a>>,
    /// `lambda_P`.
    pub lambda_p: f32,
    /// `lambda_G`.
    pub lambda_g: f32,
    /// `lambda_T w_T(x)`.
    pub temporal: Vec<f32>,
    /// `I_{t-1}^{proj}` (ignored where `temporal` is 0).
    pub previous_color: Vec<Rgb>,
}

#[inline]
fn sub(a: Rgb, b: Rgb) -> Rgb {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

impl ColorTerms<'_> {
    /// The energy `E_I` at `color`.
    pub fn energy(&self, color: &[Rgb]) -> f64 {
        let w = self.width;
        par::sum_rows(self.height, |y| {
            let mut e = 0.0f64;
            for x in 0..w {
                let i = y * w + x;
                let edge = |j: usize| {
                    let d = sub(color[i], color[j]);
                    let mut t = d.norm_sq();
                    for v in &self.views {
                        let we = v.edge_weight(i, j);
                        if we > 0.0 {
                            t += self.lambda_g * we * sub(d, sub(v.warp.color[i], v.warp.color[j])).norm_sq();
                        }
                    }
                    f64::from(t)
                };
                if x + 1 < w {
                    e += edge(i + 1);
                }
                if y + 1 < self.height {
                    e += edge(i + w);
                }
                for v in &self.views {
                    if v.w_p[i] > 0.0 {
                        e += f64::from(self.lambda_p * v.w_p[i] * sub(color[i], v.warp.color[i]).norm_sq());
                    }
                }
                if self.temporal[i] > 0.0 {
                    e += f64::from(self.temporal[i] * sub(color[i], self.previous_color[i]).norm_sq());
                }
            }
            e
        })
    }

    /// The linear system (shared by the three channels) whose solution minimises `E_I`.
    pub fn system(&self) -> GridSystem<Rgb> {
        let (w, h) = (self.width, self.height);
        let n = w * h;
        let mut right = vec![0.0f32; n];
        let mut down = vec![0.0f32; n];
        // Edge couplings a_xy = 1 + lambda_G sum_s w^s_xy, and per-edge gradient targets
        // g_xy = lambda_G sum_s w^s_xy (P^s_x - P^s_y), stored for the x -> right/down edge.
        let mut g_right = vec![[0.0f32; 3]; n];
        let mut g_down = vec![[0.0f32; 3]; n];
        par::for_each_row_mut(&mut right, w, |y, row| {
            for (x, a) in row.iter_mut().enumerate() {
                let i = y * w + x;
                if x + 1 < w {
                    *a = 1.0 + self.lambda_g * self.views.iter().map(|v| v.edge_weight(i, i + 1)).sum::<f32>();
                }
            }
        });
        par::for_each_row_mut(&mut down, w, |y, row| {
            for (x, a) in row.iter_mut().enumerate() {
                let i = y * w + x;
                if y + 1 < h {
                    *a = 1.0 + self.lambda_g * self.views.iter().map(|v| v.edge_weight(i, i + w)).sum::<f32>();
                }
            }
        });
        let edge_target = |i: usize, j: usize| {
            let mut g = [0.0f32; 3];
            for v in &self.views {
                let we = v.edge_weight(i, j);
                if we > 0.0 {
                    g = g.add(sub(v.warp.color[i], v.warp.color[j]).scale(self.lambda_g * we));
                }
            }
            g
        };
        par::for_each_row_mut(&mut g_right, w, |y, row| {
            for (x, g) in row.iter_mut().enumerate() {
                if x + 1 < w {
                    *g = edge_target(y * w + x, y * w + x + 1);
                }
            }
        });
        par::for_each_row_mut(&mut g_down, w, |y, row| {
            if y + 1 < h {
                for (x, g) in row.iter_mut().enumerate() {
                    *g = edge_target(y * w + x, (y + 1) * w + x);
                }
            }
        });
        let mut inv_diag = vec![0.0f32; n];
        let mut rhs = vec![[0.0f32; 3]; n];
        let mut rows: Vec<(&mut [f32], &mut [Rgb])> = inv_diag.chunks_mut(w).zip(rhs.chunks_mut(w)).collect();
        let work = |y: usize, (inv_row, rhs_row): &mut (&mut [f32], &mut [Rgb])| {
            for x in 0..w {
                let i = y * w + x;
                let mut diag = right[i] + down[i];
                // Gradient targets: + g for edges leaving x, - g for edges arriving at x.
                let mut b = sub(g_right[i], [0.0; 3]).add(g_down[i]);
                if x > 0 {
                    diag += right[i - 1];
                    b = sub(b, g_right[i - 1]);
                }
                if y > 0 {
                    diag += down[i - w];
                    b = sub(b, g_down[i - w]);
                }
                for v in &self.views {
                    let wp = v.w_p[i];
                    if wp > 0.0 {
                        diag += self.lambda_p * wp;
                        b = b.add(v.warp.color[i].scale(self.lambda_p * wp));
                    }
                }
                let t = self.temporal[i];
                if t > 0.0 {
                    diag += t;
                    b = b.add(self.previous_color[i].scale(t));
                }
                inv_row[x] = 1.0 / diag;
                rhs_row[x] = b;
            }
        };
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            rows.par_iter_mut().enumerate().for_each(|(y, r)| work(y, r));
        }
        #[cfg(not(feature = "parallel"))]
        rows.iter_mut().enumerate().for_each(|(y, r)| work(y, r));
        drop(rows);
        GridSystem { width: w, height: h, right, down, inv_diag, rhs }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f32 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 40) as f32) / (1u64 << 24) as f32
    }

    fn depth_terms(w: usize, h: usize, seed: &mut u64) -> DepthTerms {
        let n = w * h;
        DepthTerms {
            width: w,
            height: h,
            w_d: (0..n).map(|_| 0.1 + 5.0 * lcg(seed)).collect(),
            attach: (0..n).map(|_| if lcg(seed) < 0.2 { lcg(seed) } else { 0.0 }).collect(),
            sparse_depth: (0..n).map(|_| 2.0 + lcg(seed)).collect(),
            temporal: (0..n).map(|_| 0.05 * lcg(seed)).collect(),
            previous_depth: (0..n).map(|_| 2.0 + lcg(seed)).collect(),
            plane_weight: (0..n).map(|_| if lcg(seed) < 0.5 { 0.01 * lcg(seed) } else { 0.0 }).collect(),
            plane_depth: (0..n).map(|_| 2.0 + lcg(seed)).collect(),
        }
    }

    #[test]
    fn depth_system_is_the_energy_gradient() {
        // dE/du_i = 2 (A u - b)_i: check against central differences of the energy.
        let mut seed = 1;
        let terms = depth_terms(7, 5, &mut seed);
        let sys = terms.system();
        let u: Vec<f32> = (0..35).map(|_| 1.0 + 3.0 * lcg(&mut seed)).collect();
        for i in [0, 6, 17, 34] {
            let (x, y) = (i % 7, i / 7);
            let gs = sys.neighbour_sum(&u, i, x, y);
            let analytic = 2.0 * (f64::from(u[i]) / f64::from(sys.inv_diag[i]) - f64::from(gs));
            let h = 1e-2f32;
            let mut up = u.clone();
            up[i] += h;
            let mut dn = u.clone();
            dn[i] -= h;
            let numeric = (terms.energy(&up) - terms.energy(&dn)) / (2.0 * f64::from(h));
            assert!((analytic - numeric).abs() < 1e-2 * analytic.abs().max(1.0), "pixel {i}: {analytic} vs {numeric}");
        }
    }

    #[test]
    fn sweeps_decrease_energy_monotonically_and_converge() {
        let mut seed = 7;
        let terms = depth_terms(40, 30, &mut seed);
        let sys = terms.system();
        let mut u = vec![0.0f32; 1200];
        let mut scratch = u.clone();
        let mut last = terms.energy(&u);
        for _ in 0..300 {
            sys.sweep(&mut u, &mut scratch, 1.7);
            let e = terms.energy(&u);
            assert!(e <= last * (1.0 + 1e-6), "energy rose from {last} to {e}");
            last = e;
        }
        assert!(sys.relative_residual(&u) < 1e-4, "residual {}", sys.relative_residual(&u));
    }
}

#[cfg(test)]
mod color_tests {
    use super::*;
    use crate::camera::{Camera, Intrinsics, Rigid3};
    use crate::raster::{RgbRaster, ScalarRaster};
    use crate::render::warp::{compute_visibility, warp_view};

    #[test]
    fn color_system_is_the_energy_gradient_and_sweeps_descend() {
        let cam =
            Camera { intrinsics: Intrinsics::from_vertical_fov(0.8, 9, 7), camera_from_world: Rigid3::IDENTITY, width_px: 9, height_px: 7 };
        let mut other = cam;
        other.camera_from_world.translation.x = -0.2;
        let image =
            RgbRaster::from_vec(9, 7, (0..63).map(|i| [(i % 9) as f32 / 9.0, (i / 9) as f32 / 7.0, ((i * 7) % 5) as f32 / 5.0]).collect())
                .unwrap();
        let depth = ScalarRaster::filled(9, 7, 2.0);
        let mut warps = vec![warp_view(&cam, &depth, &cam, &image), warp_view(&cam, &depth, &other, &image)];
        for w in &mut warps {
            compute_visibility(w, 63, 0.02);
        }
        let w_p: Vec<Vec<f32>> = warps
            .iter()
            .enumerate()
            .map(|(s, w)| (0..63).map(|i| if w.valid(i) { 0.3 + 0.1 * s as f32 + 0.01 * i as f32 } else { 0.0 }).collect())
            .collect();
        let terms = ColorTerms {
            width: 9,
            height: 7,
            views: warps.iter().zip(&w_p).map(|(warp, w_p)| ColorView { warp, w_p }).collect(),
            lambda_p: 10.0,
            lambda_g: 10.0,
            temporal: (0..63).map(|i| 0.05 * (i % 3) as f32).collect(),
            previous_color: vec![[0.2, 0.4, 0.6]; 63],
        };
        let sys = terms.system();
        let u: Vec<Rgb> = (0..63).map(|i| [((i * 13) % 7) as f32 / 7.0, 0.5, ((i * 5) % 11) as f32 / 11.0]).collect();
        for i in [0usize, 4, 30, 62] {
            let (x, y) = (i % 9, i / 9);
            let gs = sys.neighbour_sum(&u, i, x, y);
            for k in 0..3 {
                let analytic = 2.0 * (f64::from(u[i][k]) / f64::from(sys.inv_diag[i]) - f64::from(gs[k]));
                let h = 1e-2f32;
                let (mut up, mut dn) = (u.clone(), u.clone());
                up[i][k] += h;
                dn[i][k] -= h;
                let numeric = (terms.energy(&up) - terms.energy(&dn)) / (2.0 * f64::from(h));
                assert!((analytic - numeric).abs() < 2e-2 * analytic.abs().max(1.0), "pixel {i} channel {k}: {analytic} vs {numeric}");
            }
        }
        let mut v = u.clone();
        let mut scratch = v.clone();
        let mut last = terms.energy(&v);
        for _ in 0..200 {
            sys.sweep(&mut v, &mut scratch, 1.6);
            let e = terms.energy(&v);
            assert!(e <= last * (1.0 + 1e-6));
            last = e;
        }
        assert!(sys.relative_residual(&v) < 1e-4);
    }
}
