//! The chosen views' per-pixel images (warped colors, visibility, validity, `w_P`), stacked
//! view after view in as few storage buffers as the device binds: one buffer where all views fit
//! in one binding, else chunks of whole views. A kernel that sums over the views runs once per
//! chunk and carries its partial sums from one chunk to the next (`shaders/common/chunk.wgsl`);
//! with one chunk it runs once, as before the split.

use std::ops::Range;

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;

/// Chunk flag (`common/chunk.wgsl`): the first chunk of the views; sums start from zero.
pub(crate) const FIRST_CHUNK: u32 = 1;
/// Chunk flag (`common/chunk.wgsl`): the last chunk; the sums are complete and are finished.
pub(crate) const LAST_CHUNK: u32 = 2;

/// How `count` views split into buffers of `per_chunk` views each (the last may hold fewer).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ViewChunks {
    /// Number of views.
    pub count: usize,
    /// Views per buffer (at least 1).
    pub per_chunk: usize,
}

impl ViewChunks {
    /// All `count` views in one buffer.
    pub fn single(count: usize) -> Self {
        Self { count, per_chunk: count.max(1) }
    }

    /// The split `count` views of `width x height` need on `ctx`'s device: as many whole views per
    /// buffer as one binding of the widest per-view image (RGB floats) holds. An error names
    /// the size where even one view's image is past the device's limit.
    pub fn for_device(ctx: &GpuContext, width: usize, height: usize, count: usize) -> Result<Self, GpuError> {
        Self::for_limit(ctx.storage_limit_bytes(), width, height, count)
    }

    /// [`Self::for_device`] for a binding limit of `limit_bytes`.
    pub fn for_limit(limit_bytes: u64, width: usize, height: usize, count: usize) -> Result<Self, GpuError> {
        if count == 0 {
            return Err(GpuError::InvalidParams { field: "inputs", reason: "no input views".into() });
        }
        let view_bytes = (width as u64) * (height as u64) * 3 * 4;
        if view_bytes > limit_bytes {
            return Err(GpuError::Size(format!(
                "one view's {width}x{height} RGB warp needs {view_bytes} bytes, the device binds at most {limit_bytes}"
            )));
        }
        let per_chunk = usize::try_from(limit_bytes / view_bytes.max(1)).unwrap_or(usize::MAX).clamp(1, count);
        Ok(Self { count, per_chunk })
    }

    /// Number of buffers.
    pub fn len(&self) -> usize {
        self.count.div_ceil(self.per_chunk)
    }

    /// Whether there are no views.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Each chunk's views, with its flags (`FIRST_CHUNK`, `LAST_CHUNK`).
    pub(crate) fn iter(&self) -> impl Iterator<Item = (Range<usize>, u32)> + '_ {
        let chunks = self.len();
        (0..chunks).map(move |c| {
            let views = c * self.per_chunk..((c + 1) * self.per_chunk).min(self.count);
            let flags = if c == 0 { FIRST_CHUNK } else { 0 } | if c + 1 == chunks { LAST_CHUNK } else { 0 };
            (views, flags)
        })
    }
}

/// The partial sums a kernel carries between chunks of `split` (`channels` floats a pixel of
/// `width x height`): none when the views are in one chunk.
pub(crate) fn partial_sums(
    ctx: &GpuContext,
    split: ViewChunks,
    width: usize,
    height: usize,
    channels: usize,
) -> Result<Option<GpuImage>, GpuError> {
    match split.len() {
        1 => Ok(None),
        _ => GpuImage::zeroed(ctx, width, height, channels).map(Some),
    }
}

/// The buffer to bind for `partial` ([`partial_sums`]): the context's placeholder when none.
pub(crate) fn partial_binding<'a>(ctx: &'a GpuContext, partial: &'a Option<GpuImage>) -> &'a wgpu::Buffer {
    partial.as_ref().map_or_else(|| ctx.placeholder(), |p| &p.buffer)
}

/// One `width x height` image per view, `channels` floats a pixel, stacked view after view in
/// the buffers of a [`ViewChunks`] split: chunk `c` is an image of `width x (height * k)` for
/// its `k` views.
#[derive(Debug)]
pub struct ViewStack {
    /// The chunks' images, in view order.
    pub chunks: Vec<GpuImage>,
    /// How the views are split.
    pub split: ViewChunks,
    /// One view's width in pixels.
    pub width: usize,
    /// One view's height in pixels.
    pub height: usize,
    /// Floats per pixel.
    pub channels: usize,
}

impl ViewStack {
    /// Zeros for the views of `split`.
    pub fn zeroed(ctx: &GpuContext, split: ViewChunks, width: usize, height: usize, channels: usize) -> Result<Self, GpuError> {
        let chunks =
            split.iter().map(|(views, _)| GpuImage::zeroed(ctx, width, height * views.len(), channels)).collect::<Result<_, _>>()?;
        Ok(Self { chunks, split, width, height, channels })
    }

    /// Uploads `data`, the views' images view after view (`width * height * channels` floats
    /// each), into the buffers of `split`.
    pub fn upload(
        ctx: &GpuContext,
        split: ViewChunks,
        width: usize,
        height: usize,
        channels: usize,
        data: &[f32],
    ) -> Result<Self, GpuError> {
        let view_floats = width * height * channels;
        if data.len() != split.count * view_floats {
            return Err(GpuError::Size(format!("{} floats for {} views of {width}x{height}x{channels}", data.len(), split.count)));
        }
        let chunks = split
            .iter()
            .map(|(views, _)| {
                GpuImage::upload(ctx, &data[views.start * view_floats..views.end * view_floats], width, height * views.len(), channels)
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { chunks, split, width, height, channels })
    }

    /// Each chunk's views and flags with its image.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (Range<usize>, u32, &GpuImage)> {
        self.split.iter().zip(&self.chunks).map(|((views, flags), image)| (views, flags, image))
    }

    /// The chunk holding view `s` and the view's first pixel in it.
    pub(crate) fn locate(&self, s: usize) -> (&GpuImage, usize) {
        (&self.chunks[s / self.split.per_chunk], (s % self.split.per_chunk) * self.width * self.height)
    }

    /// An error unless the stack holds `split`'s views of `width x height x channels`.
    pub(crate) fn check(&self, what: &str, split: ViewChunks, width: usize, height: usize, channels: usize) -> Result<(), GpuError> {
        let rows_ok = self.split.iter().zip(&self.chunks).all(|((views, _), image)| image.height == height * views.len());
        if (self.split, self.width, self.height, self.channels) == (split, width, height, channels) && rows_ok {
            Ok(())
        } else {
            Err(GpuError::Size(format!(
                "{what} holds {} views ({} a buffer) of {}x{}x{}, expected {} ({} a buffer) of {width}x{height}x{channels}",
                self.split.count, self.split.per_chunk, self.width, self.height, self.channels, split.count, split.per_chunk
            )))
        }
    }

    /// Reads every view back, view after view, blocking until the GPU is done (native only).
    #[cfg(not(target_family = "wasm"))]
    pub fn download(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        let mut out = Vec::with_capacity(self.split.count * self.width * self.height * self.channels);
        for image in &self.chunks {
            out.extend(image.download(ctx)?);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn views_split_into_whole_views_per_binding_with_first_and_last_flags() {
        let view = 10 * 4 * 3 * 4;
        let split = ViewChunks::for_limit(3 * view + 7, 10, 4, 8).unwrap();
        assert_eq!(split, ViewChunks { count: 8, per_chunk: 3 });
        let chunks: Vec<_> = split.iter().collect();
        assert_eq!(chunks, vec![(0..3, FIRST_CHUNK), (3..6, 0), (6..8, LAST_CHUNK)]);
        assert_eq!(ViewChunks::for_limit(1 << 30, 10, 4, 5).unwrap().iter().collect::<Vec<_>>(), vec![(0..5, FIRST_CHUNK | LAST_CHUNK)]);
        let error = ViewChunks::for_limit(view - 1, 10, 4, 2).unwrap_err().to_string();
        assert!(error.contains("10x4") && error.contains(&format!("{}", view - 1)), "{error}");
    }
}
