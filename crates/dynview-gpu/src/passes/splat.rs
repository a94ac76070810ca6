//! Splatting with a z-buffer on the GPU (`shaders/splat_points.wgsl`,
//! `shaders/splat_pixels.wgsl`, `shaders/splat_resolve.wgsl`): the sparse cloud into a camera (`D^`, `I^`, `m`) and a rendered
//! frame into the next camera (the temporal terms' `D_{t-1}^{proj}`, `I_{t-1}^{proj}`), as
//! dynview-core's `sparse::project_cloud` and `sparse::warp_frame`; and the sparse maps' color
//! and mask packed for the depth weights (`shaders/splat_pack.wgsl`).

use dynview_core::camera::Camera;
use dynview_core::render::transfer::PixelTransfer;
use dynview_core::scene::PointCloud;
use wgpu::util::DeviceExt;

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;

/// Splat maps on the GPU: depth (infinite where nothing landed), RGB color and mask.
#[derive(Debug)]
pub struct GpuSplat {
    /// z-depth of the nearest element.
    pub depth: GpuImage,
    /// Its color.
    pub color: GpuImage,
    /// 1 where an element landed.
    pub mask: GpuImage,
}

/// A point cloud on the GPU.
#[derive(Debug)]
pub struct GpuCloud {
    positions: wgpu::Buffer,
    colors: wgpu::Buffer,
    count: usize,
}

impl GpuCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Uploads `cloud` (positions as f32 triples, colors as packed RGBA8); an error when its
    /// positions pass the device's storage limit.
    pub fn upload(ctx: &GpuContext, cloud: &PointCloud) -> Result<Self, GpuError> {
        let bytes = cloud.len() as u64 * 12;
        let limit = ctx.storage_limit_bytes();
        if bytes > limit {
            return Err(GpuError::Size(format!(
                "a cloud of {} points needs {bytes} bytes of positions, the device binds at most {limit}",
                cloud.len()
            )));
        }
        // Buffers may not be empty: pad with one unused element.
        let mut positions: Vec<f32> = cloud.positions_world.as_flattened().to_vec();
        let mut colors: Vec<u32> = cloud.colors.iter().map(|c| u32::from_le_bytes([c[0], c[1], c[2], 255])).collect();
        positions.resize(positions.len().max(3), 0.0);
        colors.resize(colors.len().max(1), 0);
        let init = |label, contents: &[u8]| {
            ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        Ok(Self {
            positions: init("cloud positions", bytemuck::cast_slice(&positions)),
            colors: init("cloud colors", bytemuck::cast_slice(&colors)),
            count: cloud.len(),
        })
    }
}

/// `splat_points.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PointsParams {
    count: u32,
    width: u32,
    height: u32,
    first: u32,
    camera_from_world_row0: [f32; 4],
    camera_from_world_row1: [f32; 4],
    camera_from_world_row2: [f32; 4],
    focal_principal_px: [f32; 4],
}

/// `splat_pixels.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PixelsParams {
    count: u32,
    width: u32,
    height: u32,
    source_width: u32,
    transfer_row0: [f32; 4],
    transfer_row1: [f32; 4],
    transfer_row2: [f32; 4],
    transfer_offset: [f32; 4],
}

/// `splat_resolve.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ResolveParams {
    count: u32,
    pixels: u32,
    _pad0: u32,
    _pad1: u32,
}

/// `splat_pack.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PackParams {
    width: u32,
    height: u32,
    _pad0: u32,
    _pad1: u32,
}

/// The splat kernels, compiled once per device.
#[derive(Debug)]
pub struct SplatKernels {
    project_points: Kernel,
    project_pixels: Kernel,
    clear: Kernel,
    nearest_depth: Kernel,
    first_index: Kernel,
    write: Kernel,
    pack_color_mask: Kernel,
    footprint: Kernel,
}

/// `splat_footprint.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FootprintParams {
    width: u32,
    height: u32,
    radius: u32,
    _pad0: u32,
}

impl SplatKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let points = shaders::module(&ctx.device, shaders::SPLAT_POINTS);
        let pixels = shaders::module(&ctx.device, shaders::SPLAT_PIXELS);
        let resolve = shaders::module(&ctx.device, shaders::SPLAT_RESOLVE);
        let pack = shaders::module(&ctx.device, shaders::SPLAT_PACK);
        let p = [true, true, false, false, false];
        let r = [true, true, true, false, false, false, false, false];
        Self {
            project_points: Kernel::new(&ctx.device, &points, "project_points", &p, 64),
            project_pixels: Kernel::new(&ctx.device, &pixels, "project_pixels", &p, 64),
            clear: Kernel::new(&ctx.device, &resolve, "clear", &r, 64),
            nearest_depth: Kernel::new(&ctx.device, &resolve, "nearest_depth", &r, 64),
            first_index: Kernel::new(&ctx.device, &resolve, "first_index", &r, 64),
            write: Kernel::new(&ctx.device, &resolve, "write", &r, 64),
            pack_color_mask: Kernel::new(&ctx.device, &pack, "pack_color_mask", &[true, true, false], 8),
            footprint: Kernel::new(
                &ctx.device,
                &shaders::module(&ctx.device, shaders::SPLAT_FOOTPRINT),
                "footprint",
                &[true, true, true, false, false, false, false],
                8,
            ),
        }
    }

    /// Projects `cloud` into `camera` (dynview-core's `project_cloud`, without the consistency
    /// filter).
    pub fn project_cloud(&self, ctx: &GpuContext, cloud: &GpuCloud, camera: &Camera) -> Result<GpuSplat, GpuError> {
        self.project_range(ctx, cloud, 0..cloud.count, camera)
    }

    /// Projects the points `range` of `cloud` into `camera`, as [`Self::project_cloud`] the
    /// whole cloud; an empty map where the range is empty or past the cloud's end.
    pub fn project_range(
        &self,
        ctx: &GpuContext,
        cloud: &GpuCloud,
        range: std::ops::Range<usize>,
        camera: &Camera,
    ) -> Result<GpuSplat, GpuError> {
        let (first, count) = match range.end <= cloud.count {
            true => (range.start, range.len()),
            false => (0, 0),
        };
        let r = camera.camera_from_world.rotation;
        let t = camera.camera_from_world.translation;
        let k = camera.intrinsics;
        let row = |i: usize| {
            let row = r.row(i);
            [row.x as f32, row.y as f32, row.z as f32, t[i] as f32]
        };
        let params = PointsParams {
            count: count as u32,
            width: camera.width_px,
            height: camera.height_px,
            first: first as u32,
            camera_from_world_row0: row(0),
            camera_from_world_row1: row(1),
            camera_from_world_row2: row(2),
            focal_principal_px: [k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32],
        };
        let project = Projection { kernel: &self.project_points, params: bytemuck::bytes_of(&params), count };
        self.splat(ctx, project, &cloud.positions, &cloud.colors, camera)
    }

    /// Forward-warps a rendered frame (`source` camera, depth, RGB color) into `camera`
    /// (dynview-core's `warp_frame`).
    pub fn warp_frame(
        &self,
        ctx: &GpuContext,
        source: &Camera,
        depth: &GpuImage,
        color: &GpuImage,
        camera: &Camera,
    ) -> Result<GpuSplat, GpuError> {
        if (depth.width, depth.height, depth.channels) != (color.width, color.height, 1) || color.channels != 3 {
            return Err(GpuError::Size(format!(
                "frame depth {}x{}x{} and color {}x{}x{} disagree",
                depth.width, depth.height, depth.channels, color.width, color.height, color.channels
            )));
        }
        let (m, e) = PixelTransfer::new(source, camera).coefficients();
        let count = depth.width * depth.height;
        let params = PixelsParams {
            count: count as u32,
            width: camera.width_px,
            height: camera.height_px,
            source_width: depth.width as u32,
            transfer_row0: [m[0], m[1], m[2], 0.0],
            transfer_row1: [m[3], m[4], m[5], 0.0],
            transfer_row2: [m[6], m[7], m[8], 0.0],
            transfer_offset: [e[0], e[1], e[2], 0.0],
        };
        let project = Projection { kernel: &self.project_pixels, params: bytemuck::bytes_of(&params), count };
        self.splat(ctx, project, &depth.buffer, &color.buffer, camera)
    }

    /// `sparse` with every sample attached over its footprint of `radius` pixels, as
    /// dynview-core's `SplatMaps::with_footprint`, and counters whose `[1]` is the covered
    /// pixels after (for [`crate::TemporalKernels::temporal_terms`]).
    pub fn with_footprint(&self, ctx: &GpuContext, sparse: &GpuSplat, radius: usize) -> Result<(GpuSplat, GpuImage), GpuError> {
        let (w, h) = (sparse.mask.width, sparse.mask.height);
        let out = GpuSplat {
            depth: GpuImage::zeroed(ctx, w, h, 1)?,
            color: GpuImage::zeroed(ctx, w, h, 3)?,
            mask: GpuImage::zeroed(ctx, w, h, 1)?,
        };
        let counters = GpuImage::zeroed(ctx, 2, 1, 1)?;
        let params = FootprintParams { width: w as u32, height: h as u32, radius: radius as u32, _pad0: 0 };
        let buffers = [
            &sparse.depth.buffer,
            &sparse.color.buffer,
            &sparse.mask.buffer,
            &out.depth.buffer,
            &out.color.buffer,
            &out.mask.buffer,
            &counters.buffer,
        ];
        self.footprint.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, w, h);
        Ok((out, counters))
    }

    /// `sparse`'s color and mask as one RGBA image (RGB, then the mask), as the depth weights
    /// take them ([`crate::AssembleKernels::depth_system`]).
    pub fn pack_color_mask(&self, ctx: &GpuContext, sparse: &GpuSplat) -> Result<GpuImage, GpuError> {
        let (w, h) = (sparse.mask.width, sparse.mask.height);
        let out = GpuImage::zeroed(ctx, w, h, 4)?;
        let params = PackParams { width: w as u32, height: h as u32, _pad0: 0, _pad1: 0 };
        let buffers = [&sparse.color.buffer, &sparse.mask.buffer, &out.buffer];
        self.pack_color_mask.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, w, h);
        Ok(out)
    }

    fn splat(
        &self,
        ctx: &GpuContext,
        project: Projection<'_>,
        geometry: &wgpu::Buffer,
        colors: &wgpu::Buffer,
        camera: &Camera,
    ) -> Result<GpuSplat, GpuError> {
        let (w, h) = (camera.width_px as usize, camera.height_px as usize);
        let count = project.count.max(1);
        let out = GpuSplat {
            depth: GpuImage::zeroed(ctx, w, h, 1)?,
            color: GpuImage::zeroed(ctx, w, h, 3)?,
            mask: GpuImage::zeroed(ctx, w, h, 1)?,
        };
        let element_target = GpuImage::zeroed(ctx, count, 1, 1)?;
        let element_depth = GpuImage::zeroed(ctx, count, 1, 1)?;
        let element_color = GpuImage::zeroed(ctx, count, 1, 3)?;
        let zbuf = GpuImage::zeroed(ctx, w, h, 1)?;
        let winner = GpuImage::zeroed(ctx, w, h, 1)?;
        let _frame = ctx.frame();
        let elements = [&element_target.buffer, &element_depth.buffer, &element_color.buffer];
        project.kernel.dispatch(ctx, project.params, &[geometry, colors, elements[0], elements[1], elements[2]], project.count, 1);
        let resolve = ResolveParams { count: project.count as u32, pixels: (w * h) as u32, _pad0: 0, _pad1: 0 };
        let buffers =
            [elements[0], elements[1], elements[2], &zbuf.buffer, &winner.buffer, &out.depth.buffer, &out.color.buffer, &out.mask.buffer];
        let uniform = bytemuck::bytes_of(&resolve);
        self.clear.dispatch(ctx, uniform, &buffers, w * h, 1);
        for kernel in [&self.nearest_depth, &self.first_index, &self.write] {
            kernel.dispatch(ctx, uniform, &buffers, project.count, 1);
        }
        Ok(out)
    }
}

/// One projection kernel with its uniform block and the number of source elements.
struct Projection<'a> {
    kernel: &'a Kernel,
    params: &'a [u8],
    count: usize,
}

/// The uniform blocks' mirrors, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![
        mirror!(
            shaders::SPLAT_POINTS,
            "Params",
            PointsParams {
                count,
                width,
                height,
                first,
                camera_from_world_row0,
                camera_from_world_row1,
                camera_from_world_row2,
                focal_principal_px
            }
        ),
        mirror!(
            shaders::SPLAT_PIXELS,
            "Params",
            PixelsParams { count, width, height, source_width, transfer_row0, transfer_row1, transfer_row2, transfer_offset }
        ),
        mirror!(shaders::SPLAT_RESOLVE, "Params", ResolveParams { count, pixels, _pad0, _pad1 }),
        mirror!(shaders::SPLAT_PACK, "Params", PackParams { width, height, _pad0, _pad1 }),
        mirror!(shaders::SPLAT_FOOTPRINT, "FootprintParams", FootprintParams { width, height, radius, _pad0 }),
    ]
}
