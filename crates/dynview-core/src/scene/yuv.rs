//! 8-bit YUV 4:2:0 frames and their exact conversion to and from RGB (BT.601, full range,
//! chroma sited at the centre of each 2x2 block). Video frames are converted here on every
//! platform, from the decoder's own planes, so that a frame decoded natively and one decoded by
//! the browser give the same RGB to the bit.

/// A frame as three tight 8-bit planes: Y at `width x height`, U and V at
/// `ceil(width / 2) x ceil(height / 2)`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Yuv420 {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Luma, row by row.
    pub y: Vec<u8>,
    /// Blue-difference chroma, row by row.
    pub u: Vec<u8>,
    /// Red-difference chroma, row by row.
    pub v: Vec<u8>,
}

/// Plane layouts a decoder hands out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneLayout {
    /// Y plane, then U, then V (WebCodecs `I420`, ffmpeg `yuv420p`).
    I420,
    /// Y plane, then U and V interleaved (WebCodecs `NV12`).
    Nv12,
}

/// The size of the chroma planes of a `width x height` frame.
pub fn chroma_size(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(2), height.div_ceil(2))
}

/// Bytes of one tight 4:2:0 frame of `width x height`.
pub fn frame_bytes(width: u32, height: u32) -> usize {
    let (cw, ch) = chroma_size(width, height);
    width as usize * height as usize + 2 * cw as usize * ch as usize
}

fn clamp_u8(v: i32) -> u8 {
    v.clamp(0, 255) as u8
}

impl Yuv420 {
    /// Converts an RGB image (2x2 chroma blocks averaged).
    pub fn from_rgb8(image: &image::RgbImage) -> Self {
        let (width, height) = image.dimensions();
        let (cw, ch) = chroma_size(width, height);
        let mut y = Vec::with_capacity(width as usize * height as usize);
        // Chroma in 1/256 units, summed over each block, with the block's pixel count.
        let mut sums = vec![(0i64, 0i64, 0i64); cw as usize * ch as usize];
        for (x, row, pixel) in image.enumerate_pixels() {
            let [r, g, b] = pixel.0.map(i64::from);
            y.push(clamp_u8(((77 * r + 150 * g + 29 * b + 128) >> 8) as i32));
            let cell = &mut sums[(row / 2) as usize * cw as usize + (x / 2) as usize];
            cell.0 += -43 * r - 85 * g + 128 * b;
            cell.1 += 128 * r - 107 * g - 21 * b;
            cell.2 += 1;
        }
        let average = |sum: i64, n: i64| clamp_u8((128 + (sum + 128 * n).div_euclid(256 * n)) as i32);
        let u = sums.iter().map(|&(s, _, n)| average(s, n)).collect();
        let v = sums.iter().map(|&(_, s, n)| average(s, n)).collect();
        Self { width, height, y, u, v }
    }

    /// Reads a tight frame in `layout` from `bytes`, which must be exactly
    /// [`frame_bytes`]`(width, height)` long.
    pub fn from_bytes(width: u32, height: u32, layout: PlaneLayout, bytes: &[u8]) -> Option<Self> {
        if bytes.len() != frame_bytes(width, height) {
            return None;
        }
        let luma = width as usize * height as usize;
        let (y, chroma) = bytes.split_at(luma);
        let (u, v) = match layout {
            PlaneLayout::I420 => {
                let (u, v) = chroma.split_at(chroma.len() / 2);
                (u.to_vec(), v.to_vec())
            }
            PlaneLayout::Nv12 => (chroma.iter().step_by(2).copied().collect(), chroma.iter().skip(1).step_by(2).copied().collect()),
        };
        Some(Self { width, height, y: y.to_vec(), u, v })
    }

    /// The frame as tight `I420` bytes (Y, U, V).
    pub fn to_i420_bytes(&self) -> Vec<u8> {
        [self.y.as_slice(), &self.u, &self.v].concat()
    }

    /// Converts to RGB, interpolating chroma bilinearly between block centres (edges clamped).
    pub fn to_rgb8(&self) -> image::RgbImage {
        let (w, h) = (self.width as usize, self.height as usize);
        let (cw, ch) = chroma_size(self.width, self.height);
        let (cw, ch) = (cw as usize, ch as usize);
        // Neighbouring block and weight (out of 4) for each pixel coordinate: the pixel lies a
        // quarter block from its own block's centre, towards the neighbour.
        let taps = |n: usize, blocks: usize| -> Vec<(usize, usize)> {
            (0..n)
                .map(|i| {
                    let own = i / 2;
                    let other = if i % 2 == 0 { own.saturating_sub(1) } else { (own + 1).min(blocks - 1) };
                    (own, other)
                })
                .collect()
        };
        let (xs, ys) = (taps(w, cw), taps(h, ch));
        let mut out = image::RgbImage::new(self.width, self.height);
        for (row, &(y0, y1)) in ys.iter().enumerate() {
            for (x, &(x0, x1)) in xs.iter().enumerate() {
                let sample = |plane: &[u8]| {
                    let at = |cy: usize, cx: usize| i32::from(plane[cy * cw + cx]);
                    9 * at(y0, x0) + 3 * at(y0, x1) + 3 * at(y1, x0) + at(y1, x1)
                };
                // Chroma in 1/16 units, centred on zero.
                let cb = sample(&self.u) - 16 * 128;
                let cr = sample(&self.v) - 16 * 128;
                let luma = i32::from(self.y[row * w + x]) << 16;
                // Full-range BT.601: R = Y + 1.402 Cr, G = Y - 0.344 Cb - 0.714 Cr, B = Y + 1.772 Cb
                // (coefficients in 1/65536, chroma in 1/16: products in 1/2^20).
                let r = (luma + ((91881 * cr) >> 4) + (1 << 15)) >> 16;
                let g = (luma - ((22554 * cb + 46802 * cr) >> 4) + (1 << 15)) >> 16;
                let b = (luma + ((116130 * cb) >> 4) + (1 << 15)) >> 16;
                out.put_pixel(x as u32, row as u32, image::Rgb([clamp_u8(r), clamp_u8(g), clamp_u8(b)]));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: u32, h: u32) -> image::RgbImage {
        image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 255 / w) as u8, (y * 255 / h) as u8, ((x + y) * 2).min(255) as u8]))
    }

    #[test]
    fn flat_colors_survive_the_round_trip_within_two_codes() {
        for rgb in [[0u8, 0, 0], [255, 255, 255], [200, 30, 90], [12, 240, 128], [128, 128, 128]] {
            let image = image::RgbImage::from_pixel(5, 3, image::Rgb(rgb));
            let back = Yuv420::from_rgb8(&image).to_rgb8();
            for p in back.pixels() {
                for c in 0..3 {
                    assert!((i32::from(p.0[c]) - i32::from(rgb[c])).abs() <= 2, "{rgb:?} came back as {:?}", p.0);
                }
            }
        }
    }

    #[test]
    fn odd_sizes_have_rounded_up_chroma_planes_and_bytes_round_trip() {
        let yuv = Yuv420::from_rgb8(&gradient(7, 5));
        assert_eq!((yuv.u.len(), yuv.v.len()), (4 * 3, 4 * 3));
        let bytes = yuv.to_i420_bytes();
        assert_eq!(bytes.len(), frame_bytes(7, 5));
        assert_eq!(Yuv420::from_bytes(7, 5, PlaneLayout::I420, &bytes), Some(yuv.clone()));
        let mut nv12 = yuv.y.clone();
        nv12.extend(yuv.u.iter().zip(&yuv.v).flat_map(|(&u, &v)| [u, v]));
        assert_eq!(Yuv420::from_bytes(7, 5, PlaneLayout::Nv12, &nv12), Some(yuv));
        assert_eq!(Yuv420::from_bytes(7, 5, PlaneLayout::I420, &bytes[1..]), None);
    }

    #[test]
    fn a_smooth_image_comes_back_close() {
        let image = gradient(64, 48);
        let back = Yuv420::from_rgb8(&image).to_rgb8();
        let worst =
            image.pixels().zip(back.pixels()).flat_map(|(a, b)| (0..3).map(move |c| (i32::from(a.0[c]) - i32::from(b.0[c])).abs())).max();
        // Channels step by up to 4 codes per pixel: chroma subsampling smooths that a little.
        assert!(worst.unwrap() <= 4, "worst channel error {worst:?}");
    }
}
