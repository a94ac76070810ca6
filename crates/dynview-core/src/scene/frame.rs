//! Encoding and decoding the per-camera frame files (native and wasm32 alike).

use super::error::{SceneError, SceneResult};
use super::limits::MAX_IMAGE_SIDE_PX;
use super::manifest::FrameFormat;
use crate::raster::RgbRaster;

/// JPEG quality of frames written by the scene writer.
pub const JPEG_QUALITY: u8 = 92;

/// Decodes frame bytes of the given format, refusing images whose header claims a size other
/// than `width x height` before decoding the pixels.
pub fn decode_frame(bytes: &[u8], format: FrameFormat, width: u32, height: u32, file: &str) -> SceneResult<RgbRaster> {
    let image_format = image_format(format, file)?;
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), image_format);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE_PX);
    limits.max_image_height = Some(MAX_IMAGE_SIDE_PX);
    limits.max_alloc = Some(u64::from(width) * u64::from(height) * 16 + (1 << 20));
    reader.limits(limits);
    let decoded = reader.decode().map_err(|source| SceneError::Image { file: file.to_owned(), source })?;
    if (decoded.width(), decoded.height()) != (width, height) {
        return Err(SceneError::invalid(
            file,
            "(image size)",
            format!("{}x{}, expected {width}x{height}", decoded.width(), decoded.height()),
        ));
    }
    Ok(RgbRaster::from_rgb8(&decoded.to_rgb8()))
}

/// Encodes a frame in the package's frame format.
pub fn encode_frame(image: &image::RgbImage, format: FrameFormat, file: &str) -> SceneResult<Vec<u8>> {
    let mut out = Vec::new();
    let result = match image_format(format, file)? {
        image::ImageFormat::Jpeg => image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, JPEG_QUALITY).encode_image(image),
        other => image.write_to(&mut std::io::Cursor::new(&mut out), other),
    };
    result.map_err(|source| SceneError::Image { file: file.to_owned(), source })?;
    Ok(out)
}

/// The image codec of an image frame format; video formats have none (their frames are not
/// files of their own).
pub fn image_format(format: FrameFormat, file: &str) -> SceneResult<image::ImageFormat> {
    match format {
        FrameFormat::Jpeg => Ok(image::ImageFormat::Jpeg),
        FrameFormat::Png => Ok(image::ImageFormat::Png),
        FrameFormat::Webp => Ok(image::ImageFormat::WebP),
        FrameFormat::Vp9 => Err(SceneError::invalid(file, "frame_format", "vp9 frames are a video per camera, not image files")),
    }
}
