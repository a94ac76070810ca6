//! Push-pull hole filling (a pyramid fill): holes take the weighted mean of coarser levels.

use super::pyramid::{Pixel, half};
use crate::raster::Raster;

/// Fills pixels of weight 0 in `values` from their surroundings. `weights` are per-pixel
/// confidences (1 for known, 0 for holes). Known pixels keep their values; holes get a
/// smooth blend of the nearest known values. With no known pixel at all, returns `fallback`
/// everywhere.
pub fn fill<T: Pixel>(values: &Raster<T>, weights: &Raster<f32>, fallback: T) -> Raster<T> {
    // Pull: premultiplied sums, down to a single pixel.
    let mut levels: Vec<(Raster<T>, Raster<f32>)> = vec![(
        Raster {
            width: values.width,
            height: values.height,
            data: values.data.iter().zip(&weights.data).map(|(v, &w)| v.scale(w)).collect(),
        },
        weights.clone(),
    )];
    loop {
        let (v, w) = &levels[levels.len() - 1];
        if v.width == 1 && v.height == 1 {
            break;
        }
        let (nw, nh) = (half(v.width), half(v.height));
        let mut nv = Raster::filled(nw, nh, T::default());
        let mut nwt = Raster::filled(nw, nh, 0.0f32);
        for y in 0..nh {
            for x in 0..nw {
                let mut sv = T::default();
                let mut sw = 0.0;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = (2 * x + dx, 2 * y + dy);
                    if sx < v.width && sy < v.height {
                        sv = sv.add(v.get(sx, sy));
                        sw += w.get(sx, sy);
                    }
                }
                // Saturate: a coarse pixel with full support counts as known.
                let scale = if sw > 1.0 { 1.0 / sw } else { 1.0 };
                nv.set(x, y, sv.scale(scale));
                nwt.set(x, y, sw.min(1.0));
            }
        }
        levels.push((nv, nwt));
    }
    // Push: from coarse to fine, complete each level with the upsampled coarser one.
    let (top_v, top_w) = &levels[levels.len() - 1];
    let mut filled = Raster::filled(1, 1, if top_w.data[0] > 0.0 { top_v.data[0].scale(1.0 / top_w.data[0]) } else { fallback });
    for (v, w) in levels.iter().rev().skip(1) {
        let coarse = super::pyramid::upsample(&filled, v.width, v.height);
        let mut next = Raster::filled(v.width, v.height, T::default());
        for i in 0..next.data.len() {
            let wi = w.data[i].min(1.0);
            let known = if w.data[i] > 0.0 { v.data[i].scale(1.0 / w.data[i].max(1.0)) } else { T::default() };
            // Premultiplied blend: known part plus the coarse fill for the missing share.
            next.data[i] = if w.data[i] >= 1.0 { known } else { v.data[i].add(coarse.data[i].scale(1.0 - wi)) };
        }
        filled = next;
    }
    filled
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::ScalarRaster;

    #[test]
    fn known_pixels_stay_and_holes_fill_between() {
        let mut v = ScalarRaster::filled(16, 1, 0.0);
        let mut w = ScalarRaster::filled(16, 1, 0.0);
        v.data[0] = 1.0;
        w.data[0] = 1.0;
        v.data[15] = 3.0;
        w.data[15] = 1.0;
        let f = fill(&v, &w, 0.0);
        assert_eq!(f.data[0], 1.0);
        assert_eq!(f.data[15], 3.0);
        assert!(f.data.iter().all(|&x| (1.0..=3.0).contains(&x)), "{:?}", f.data);
        // Closer to the left value near the left end.
        assert!(f.data[2] < f.data[13]);
    }

    #[test]
    fn constant_known_values_fill_with_that_constant() {
        let mut v = ScalarRaster::filled(37, 23, 0.0);
        let mut w = ScalarRaster::filled(37, 23, 0.0);
        for i in (0..v.data.len()).step_by(7) {
            v.data[i] = 2.5;
            w.data[i] = 1.0;
        }
        let f = fill(&v, &w, 0.0);
        assert!(f.data.iter().all(|&x| (x - 2.5).abs() < 1e-5));
        let empty = fill(&v, &ScalarRaster::filled(37, 23, 0.0), 9.0);
        assert!(empty.data.iter().all(|&x| x == 9.0));
    }
}
