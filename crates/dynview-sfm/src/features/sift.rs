//! SIFT features (OpenCV) with RootSIFT descriptors, and their work-folder files.

use std::path::Path;

use opencv::core::{Mat, Size, Vector};
use opencv::prelude::*;
use opencv::{features2d, imgcodecs, imgproc};

use dynview_core::fsutil::write_atomic;

use crate::error::{SfmError, SfmResult};

/// Length of a SIFT descriptor.
pub const DESCRIPTOR_LEN: usize = 128;
const MAGIC: &[u8; 8] = b"DVSIFT1\0";

/// How features are extracted.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FeatureOptions {
    /// Most features kept per image (the strongest).
    pub max_features: usize,
    /// Images larger than this (longer side, px) are downscaled for extraction; keypoints are
    /// reported in full-resolution pixels.
    pub max_image_size_px: u32,
    /// OpenCV's SIFT contrast threshold (COLMAP's default peak threshold 0.02/3 equals 0.02
    /// here); lower finds more features in low-contrast video.
    pub contrast_threshold: f64,
    /// Which revision of the extraction made the features ([`EXTRACTION_REVISION`] unless
    /// set otherwise): part of every work-folder key that features feed, so a work folder
    /// made by an earlier revision extracts again rather than mixing the two. Settings saved
    /// before it existed read as revision 1 (so `dynview merge` names them as different).
    #[serde(default = "first_revision")]
    pub revision: u32,
}

impl Default for FeatureOptions {
    fn default() -> Self {
        Self { max_features: 8192, max_image_size_px: 2000, contrast_threshold: 0.02, revision: EXTRACTION_REVISION }
    }
}

/// The revision of features saved before revisions were recorded.
fn first_revision() -> u32 {
    1
}

/// The revision of the extraction. 2: keypoints moved by [`OPENCV_SIFT_OFFSET_PX`] onto
/// dynview's pixel convention (revision 1 reported them a quarter pixel right of and below
/// where they are).
pub const EXTRACTION_REVISION: u32 = 2;

/// How far right and down of the true position OpenCV's SIFT reports a keypoint, in pixels of
/// the image it was given. SIFT's first octave is the image doubled; OpenCV halves positions
/// found there, but the doubled image's pixel centres sit at `2 x + 0.5`, so a position comes
/// back a quarter pixel too far in both axes (OpenCV 4.8 added `enable_precise_upscale` for
/// this; Debian 12 has 4.6). Measured on Gaussian blobs at known sub-pixel centres
/// (`tests::keypoints_sit_on_the_blobs_they_find`): +0.250 px at sigma 1.5-4 px, +0.23 at 10.
/// A constant shift, so it cost little where principal points were refined, but with a given
/// or centred principal point it turned each camera by `0.25 / focal` radians.
pub const OPENCV_SIFT_OFFSET_PX: f64 = 0.25;

/// The features of one image: keypoint positions (pixels, centres at integers) and quantized
/// RootSIFT descriptors.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Features {
    /// Keypoint positions in full-resolution pixels.
    pub xy: Vec<[f32; 2]>,
    /// `xy.len() * 128` descriptor bytes.
    pub descriptors: Vec<u8>,
}

impl Features {
    /// Number of features.
    pub fn len(&self) -> usize {
        self.xy.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.xy.is_empty()
    }

    /// The descriptors as an `n x 128` float matrix for OpenCV's matchers.
    pub fn descriptor_mat(&self) -> SfmResult<Mat> {
        let floats: Vec<f32> = self.descriptors.iter().map(|&b| f32::from(b)).collect();
        let mat =
            Mat::new_rows_cols_with_data(self.len() as i32, DESCRIPTOR_LEN as i32, &floats).map_err(SfmError::cv("descriptor matrix"))?;
        mat.try_clone().map_err(SfmError::cv("descriptor matrix"))
    }

    /// Serializes to the work-folder format.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(12 + self.len() * (8 + DESCRIPTOR_LEN));
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&(self.len() as u32).to_le_bytes());
        for p in &self.xy {
            out.extend_from_slice(&p[0].to_le_bytes());
            out.extend_from_slice(&p[1].to_le_bytes());
        }
        out.extend_from_slice(&self.descriptors);
        out
    }

    /// Parses the work-folder format; `path` names the file in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> SfmResult<Self> {
        let bad = |problem: &str| SfmError::WorkFile { path: path.to_path_buf(), problem: problem.into() };
        if bytes.len() < 12 || &bytes[..8] != MAGIC {
            return Err(bad("not a dynview feature file"));
        }
        let n = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
        if bytes.len() != 12 + n * (8 + DESCRIPTOR_LEN) {
            return Err(bad("length does not match the feature count"));
        }
        let xy = bytes[12..12 + 8 * n]
            .chunks_exact(8)
            .map(|c| [f32::from_le_bytes([c[0], c[1], c[2], c[3]]), f32::from_le_bytes([c[4], c[5], c[6], c[7]])])
            .collect();
        Ok(Self { xy, descriptors: bytes[12 + 8 * n..].to_vec() })
    }

    /// Writes the features atomically.
    pub fn write(&self, path: &Path) -> SfmResult<()> {
        write_atomic(path, &self.to_bytes()).map_err(SfmError::io(path))
    }

    /// Reads features written by [`Features::write`].
    pub fn read(path: &Path) -> SfmResult<Self> {
        let bytes = std::fs::read(path).map_err(SfmError::io(path))?;
        Self::from_bytes(&bytes, path)
    }
}

/// Reads `path` as grayscale.
pub fn read_gray(path: &Path) -> SfmResult<Mat> {
    let decode = |problem: String| SfmError::Decode { path: path.to_path_buf(), problem };
    let image = imgcodecs::imread(path, imgcodecs::IMREAD_GRAYSCALE).map_err(|e| decode(e.to_string()))?;
    if image.empty() {
        return Err(decode("not an image OpenCV can read".into()));
    }
    Ok(image)
}

/// SIFT features of a grayscale image, strongest first, at most `options.max_features`.
pub fn extract_gray(gray: &Mat, options: &FeatureOptions) -> SfmResult<Features> {
    extract_gray_masked(gray, &Mat::default(), options)
}

/// [`extract_gray`] where `mask` (8-bit, the image's size; empty: everywhere) is non-zero.
pub fn extract_gray_masked(gray: &Mat, mask: &Mat, options: &FeatureOptions) -> SfmResult<Features> {
    let longest = gray.cols().max(gray.rows()) as f64;
    let scale = (f64::from(options.max_image_size_px) / longest).min(1.0);
    let mut small = Mat::default();
    let mut small_mask = Mat::default();
    let (image, mask) = if scale < 1.0 {
        let size = Size::new((f64::from(gray.cols()) * scale).round() as i32, (f64::from(gray.rows()) * scale).round() as i32);
        imgproc::resize(gray, &mut small, size, 0.0, 0.0, imgproc::INTER_AREA).map_err(SfmError::cv("downscaling for SIFT"))?;
        if !mask.empty() {
            imgproc::resize(mask, &mut small_mask, size, 0.0, 0.0, imgproc::INTER_NEAREST).map_err(SfmError::cv("downscaling a mask"))?;
        }
        (&small, &small_mask)
    } else {
        (gray, mask)
    };
    let mut sift = features2d::SIFT::create(options.max_features as i32, 3, options.contrast_threshold, 10.0, 1.6)
        .map_err(SfmError::cv("creating SIFT"))?;
    let mut keypoints = Vector::new();
    let mut descriptors = Mat::default();
    sift.detect_and_compute(image, mask, &mut keypoints, &mut descriptors, false).map_err(SfmError::cv("SIFT detection"))?;
    let n = keypoints.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| {
        let (ra, rb) = (keypoints.get(a).map_or(0.0, |k| k.response()), keypoints.get(b).map_or(0.0, |k| k.response()));
        rb.total_cmp(&ra)
    });
    order.truncate(options.max_features);
    let back = 1.0 / scale;
    let mut out = Features::default();
    for &i in &order {
        let k = keypoints.get(i).map_err(SfmError::cv("keypoint"))?;
        // Pixel centres at integers, like dynview, once OpenCV's quarter pixel is taken off.
        let (x, y) = (f64::from(k.pt().x) - OPENCV_SIFT_OFFSET_PX, f64::from(k.pt().y) - OPENCV_SIFT_OFFSET_PX);
        out.xy.push([((x + 0.5) * back - 0.5) as f32, ((y + 0.5) * back - 0.5) as f32]);
        let row = descriptors.at_row::<f32>(i as i32).map_err(SfmError::cv("descriptor row"))?;
        out.descriptors.extend(root_sift(row));
    }
    Ok(out)
}

/// RootSIFT (L1 normalisation, square root), quantized to bytes like COLMAP (x 512).
fn root_sift(descriptor: &[f32]) -> [u8; DESCRIPTOR_LEN] {
    let l1: f32 = descriptor.iter().map(|v| v.abs()).sum::<f32>().max(1e-12);
    let mut out = [0u8; DESCRIPTOR_LEN];
    for (o, v) in out.iter_mut().zip(descriptor) {
        *o = ((v.abs() / l1).sqrt() * 512.0).round().min(255.0) as u8;
    }
    out
}

/// Reads `path` and extracts its features.
pub fn extract_file(path: &Path, options: &FeatureOptions) -> SfmResult<Features> {
    extract_gray(&read_gray(path)?, options)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grey image of `width x height` with bright Gaussian blobs of `sigma_px` on a grid,
    /// each at a sub-pixel centre (pixel centres at integers); returns it and the centres.
    fn blobs(width: usize, height: usize, sigma_px: f64) -> (Mat, Vec<[f64; 2]>) {
        let spacing = (8.0 * sigma_px).ceil() as usize + 8;
        let mut centres = Vec::new();
        let mut image = vec![60.0f64; width * height];
        let (mut row, mut col) = (0usize, 0usize);
        for cy in (spacing..height - spacing).step_by(spacing) {
            row += 1;
            for cx in (spacing..width - spacing).step_by(spacing) {
                col += 1;
                // Sub-pixel offsets spread over the pixel, repeatable.
                let centre = [cx as f64 + ((col * 7) % 10) as f64 / 10.0 - 0.45, cy as f64 + ((row * 3 + col) % 10) as f64 / 10.0 - 0.45];
                centres.push(centre);
                let reach = (4.0 * sigma_px).ceil() as usize;
                for y in cy - reach..=cy + reach {
                    for x in cx - reach..=cx + reach {
                        let r2 = (x as f64 - centre[0]).powi(2) + (y as f64 - centre[1]).powi(2);
                        image[y * width + x] += 150.0 * (-r2 / (2.0 * sigma_px * sigma_px)).exp();
                    }
                }
            }
        }
        let bytes: Vec<u8> = image.iter().map(|v| v.round().clamp(0.0, 255.0) as u8).collect();
        let mat = Mat::new_rows_cols_with_data(height as i32, width as i32, &bytes).unwrap().try_clone().unwrap();
        (mat, centres)
    }

    /// Mean offset (px) of the keypoints nearest to each centre, and how many centres have one
    /// within half a pixel.
    fn offsets(features: &Features, centres: &[[f64; 2]]) -> ([f64; 2], usize) {
        let mut sum = [0.0; 2];
        let mut found = 0;
        for c in centres {
            let nearest = features
                .xy
                .iter()
                .map(|p| [f64::from(p[0]) - c[0], f64::from(p[1]) - c[1]])
                .min_by(|a, b| (a[0].hypot(a[1])).total_cmp(&b[0].hypot(b[1])));
            if let Some(d) = nearest.filter(|d| d[0].hypot(d[1]) < 0.5) {
                sum = [sum[0] + d[0], sum[1] + d[1]];
                found += 1;
            }
        }
        ([sum[0] / found.max(1) as f64, sum[1] / found.max(1) as f64], found)
    }

    #[test]
    fn options_saved_before_revisions_read_as_the_first_revision() {
        let old: FeatureOptions =
            serde_json::from_str(r#"{"max_features":8192,"max_image_size_px":2000,"contrast_threshold":0.02}"#).unwrap();
        assert_eq!(old.revision, 1);
        assert_ne!(old, FeatureOptions::default());
    }

    #[test]
    fn keypoints_sit_on_the_blobs_they_find() {
        for sigma_px in [1.5, 4.0] {
            let (image, centres) = blobs(640, 480, sigma_px);
            let features = extract_gray(&image, &FeatureOptions::default()).unwrap();
            let (mean, found) = offsets(&features, &centres);
            assert!(found * 10 >= centres.len() * 9, "sigma {sigma_px}: {found} of {} blobs found", centres.len());
            // Uncorrected, OpenCV's positions are 0.25 px off in both axes.
            assert!(mean[0].abs() < 0.03 && mean[1].abs() < 0.03, "sigma {sigma_px}: mean offset {mean:?} px");
        }
    }

    #[test]
    fn keypoints_of_a_downscaled_extraction_are_in_full_resolution_pixels() {
        let (image, centres) = blobs(960, 720, 5.0);
        let options = FeatureOptions { max_image_size_px: 480, ..FeatureOptions::default() };
        let features = extract_gray(&image, &options).unwrap();
        let (mean, found) = offsets(&features, &centres);
        assert!(found * 10 >= centres.len() * 9, "{found} of {} blobs found", centres.len());
        assert!(mean[0].abs() < 0.05 && mean[1].abs() < 0.05, "mean offset {mean:?} px");
    }
}
