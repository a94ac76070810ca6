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
}

impl Default for FeatureOptions {
    fn default() -> Self {
        Self { max_features: 8192, max_image_size_px: 2000, contrast_threshold: 0.02 }
    }
}

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
    let longest = gray.cols().max(gray.rows()) as f64;
    let scale = (f64::from(options.max_image_size_px) / longest).min(1.0);
    let mut small = Mat::default();
    let image = if scale < 1.0 {
        let size = Size::new((f64::from(gray.cols()) * scale).round() as i32, (f64::from(gray.rows()) * scale).round() as i32);
        imgproc::resize(gray, &mut small, size, 0.0, 0.0, imgproc::INTER_AREA).map_err(SfmError::cv("downscaling for SIFT"))?;
        &small
    } else {
        gray
    };
    let mut sift = features2d::SIFT::create(options.max_features as i32, 3, options.contrast_threshold, 10.0, 1.6)
        .map_err(SfmError::cv("creating SIFT"))?;
    let mut keypoints = Vector::new();
    let mut descriptors = Mat::default();
    sift.detect_and_compute(image, &Mat::default(), &mut keypoints, &mut descriptors, false).map_err(SfmError::cv("SIFT detection"))?;
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
        // OpenCV's SIFT reports positions with pixel centres at integers, like dynview.
        let (x, y) = (f64::from(k.pt().x), f64::from(k.pt().y));
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
