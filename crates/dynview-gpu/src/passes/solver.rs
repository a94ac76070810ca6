//! The red-black over-relaxed Gauss-Seidel solver of dynview-core's grid systems on the GPU, in
//! one of two kernels that give the same result ([`SweepKernel`]): one colour per dispatch over
//! the whole grid (`shaders/red_black.wgsl`), or up to [`HALO`] colours per dispatch on
//! workgroup-local tiles (`shaders/red_black_tiled.wgsl`), the unknowns alternating between two
//! buffers. Either way all sweeps of a solve are in one compute pass.

#[cfg(not(target_family = "wasm"))]
use dynview_core::raster::Rgb;
#[cfg(not(target_family = "wasm"))]
use dynview_core::render::solve::GridSystem;
#[cfg(not(target_family = "wasm"))]
use wgpu::util::DeviceExt;

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
#[cfg(not(target_family = "wasm"))]
use crate::device::readback::read_blocking;
use crate::device::shaders;
use crate::passes::assemble::GpuSystem;

/// `red_black.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SweepParams {
    width: u32,
    height: u32,
    parity: u32,
    channels: u32,
    omega: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// `red_black_tiled.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TiledSweepParams {
    width: u32,
    height: u32,
    parity: u32,
    channels: u32,
    omega: f32,
    half_sweeps: u32,
    _pad0: u32,
    _pad1: u32,
}

/// Side of the square workgroup of `red_black.wgsl`.
const WORKGROUP: u32 = 8;
/// Side of the square tile a workgroup of `red_black_tiled.wgsl` writes (its workgroup size).
const TILE: u32 = 16;
/// Most half-sweeps one dispatch runs: the halo around each tile (`HALO` in the WGSL).
pub(crate) const HALO: usize = 4;

/// Half-sweeps per dispatch for `sweeps` red-black sweeps: `2 * sweeps` spread evenly over an
/// even number of dispatches of at most [`HALO`] each, so that the unknowns, alternating
/// between two buffers, end where they began.
fn dispatch_plan(sweeps: usize) -> Vec<usize> {
    let half_sweeps = 2 * sweeps;
    let mut dispatches = half_sweeps.div_ceil(HALO);
    dispatches += dispatches % 2;
    (0..dispatches).map(|j| half_sweeps * (j + 1) / dispatches - half_sweeps * j / dispatches).collect()
}

/// Which kernel runs the red-black sweeps. Both give the same result (the same arithmetic on
/// every pixel in the same order of colours); they differ in dispatches and memory traffic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepKernel {
    /// One colour per dispatch over the whole grid (`red_black.wgsl`).
    PerColour,
    /// Up to [`HALO`] colours per dispatch on 16x16 tiles in workgroup memory
    /// (`red_black_tiled.wgsl`): a quarter of the dispatches, and the system read once per
    /// dispatch instead of once per colour.
    Tiled,
}

impl SweepKernel {
    /// The kernel for an adapter: per colour on a CPU adapter (lavapipe, SwiftShader), where
    /// workgroup memory and barriers are dear (on lavapipe the tiled solves take 3.7 times as
    /// long: `docs/results/bench.md`), tiled on a GPU.
    pub fn for_adapter(info: &wgpu::AdapterInfo) -> Self {
        match info.device_type {
            wgpu::DeviceType::Cpu => Self::PerColour,
            _ => Self::Tiled,
        }
    }
}

/// The compiled sweep pipeline.
#[derive(Debug)]
pub struct GridSolver {
    sweep: Kernel,
    kind: SweepKernel,
}

impl GridSolver {
    /// Compiles the sweep kernel for `ctx`'s adapter ([`SweepKernel::for_adapter`]).
    pub fn new(ctx: &GpuContext) -> Self {
        Self::with_kernel(ctx, SweepKernel::for_adapter(&ctx.adapter_info))
    }

    /// Compiles the sweep kernel `kind`.
    pub fn with_kernel(ctx: &GpuContext, kind: SweepKernel) -> Self {
        let device = &ctx.device;
        let sweep = match kind {
            SweepKernel::PerColour => {
                Kernel::new(device, &shaders::module(device, shaders::RED_BLACK), "sweep", &[true, true, true, true, false], WORKGROUP)
            }
            SweepKernel::Tiled => Kernel::new(
                device,
                &shaders::module(device, shaders::RED_BLACK_TILED),
                "sweeps",
                &[true, true, true, true, true, false],
                TILE,
            ),
        };
        Self { sweep, kind }
    }

    /// The kernel that runs the sweeps.
    pub fn kernel(&self) -> SweepKernel {
        self.kind
    }

    /// `sweeps` red-black sweeps of a system already on the GPU, on `u` (in place; `u`'s
    /// channels share the system).
    pub fn solve_on_gpu(&self, ctx: &GpuContext, sys: &GpuSystem, u: &GpuImage, sweeps: usize, omega: f32) -> Result<(), GpuError> {
        let (w, h) = (u.width, u.height);
        for (name, image, channels) in
            [("right", &sys.right, 1), ("down", &sys.down, 1), ("inv_diag", &sys.inv_diag, 1), ("rhs", &sys.rhs, u.channels)]
        {
            if (image.width, image.height, image.channels) != (w, h, channels) {
                return Err(GpuError::Size(format!(
                    "system {name} is {}x{}x{}, unknowns {w}x{h}x{}",
                    image.width, image.height, image.channels, u.channels
                )));
            }
        }
        // The tiled kernel's second buffer of unknowns.
        let scratch = match self.kind {
            SweepKernel::Tiled => Some(GpuImage::scratch(ctx, w, h, u.channels)?),
            SweepKernel::PerColour => None,
        };
        let scratch = scratch.as_ref().map_or(&u.buffer, |s| &s.buffer);
        let buffers = [&sys.right.buffer, &sys.down.buffer, &sys.inv_diag.buffer, &sys.rhs.buffer, &u.buffer, scratch];
        self.record(ctx, buffers, w, h, u.channels as u32, sweeps, omega);
        Ok(())
    }

    /// Records `sweeps` sweeps over the buffers (right, down, inv_diag, rhs, u, and a scratch of
    /// u's size that only the tiled kernel uses): per colour, `2 * sweeps` dispatches; tiled,
    /// the dispatches of [`dispatch_plan`], from u to the scratch and back.
    #[allow(clippy::too_many_arguments)]
    fn record(&self, ctx: &GpuContext, buffers: [&wgpu::Buffer; 6], width: usize, height: usize, channels: u32, sweeps: usize, omega: f32) {
        let [right, down, inv_diag, rhs, u, scratch] = buffers;
        let (w, h) = (width as u32, height as u32);
        if self.kind == SweepKernel::PerColour {
            let params = |parity| SweepParams { width: w, height: h, parity, channels, omega, _pad0: 0, _pad1: 0, _pad2: 0 };
            let (red, black) = (params(0), params(1));
            let sequence: Vec<usize> = (0..2 * sweeps).map(|i| i % 2).collect();
            let uniforms = [bytemuck::bytes_of(&red), bytemuck::bytes_of(&black)];
            self.sweep.dispatch_sequence(ctx, &uniforms, &sequence, &[right, down, inv_diag, rhs, u], width, height);
            return;
        }
        let mut done = 0;
        for (j, half_sweeps) in dispatch_plan(sweeps).into_iter().enumerate() {
            let parity = (done % 2) as u32;
            let params =
                TiledSweepParams { width: w, height: h, parity, channels, omega, half_sweeps: half_sweeps as u32, _pad0: 0, _pad1: 0 };
            let (from, to) = if j % 2 == 0 { (u, scratch) } else { (scratch, u) };
            self.sweep.dispatch(ctx, bytemuck::bytes_of(&params), &[right, down, inv_diag, rhs, from, to], width, height);
            done += half_sweeps;
        }
    }

    /// `sweeps` red-black sweeps of the depth system `sys` on `u` (in place), as
    /// [`GridSystem::sweep`] does them. Native only: it reads the result back, blocking.
    #[cfg(not(target_family = "wasm"))]
    pub fn solve_depth(&self, ctx: &GpuContext, sys: &GridSystem<f32>, u: &mut [f32], sweeps: usize, omega: f32) -> Result<(), GpuError> {
        self.solve(ctx, sys, &sys.rhs, u, 1, sweeps, omega)
    }

    /// `sweeps` red-black sweeps of the color system `sys` on `u` (in place; the three
    /// channels share the system). Native only: it reads the result back, blocking.
    #[cfg(not(target_family = "wasm"))]
    pub fn solve_color(&self, ctx: &GpuContext, sys: &GridSystem<Rgb>, u: &mut [Rgb], sweeps: usize, omega: f32) -> Result<(), GpuError> {
        let rhs: &[f32] = bytemuck::cast_slice(&sys.rhs);
        self.solve(ctx, sys, rhs, bytemuck::cast_slice_mut(u), 3, sweeps, omega)
    }

    #[cfg(not(target_family = "wasm"))]
    #[allow(clippy::too_many_arguments)]
    fn solve<T>(
        &self,
        ctx: &GpuContext,
        sys: &GridSystem<T>,
        rhs: &[f32],
        u: &mut [f32],
        channels: u32,
        sweeps: usize,
        omega: f32,
    ) -> Result<(), GpuError> {
        let n = sys.width * sys.height;
        let sizes_agree = [sys.right.len(), sys.down.len(), sys.inv_diag.len()].iter().all(|&l| l == n)
            && rhs.len() == n * channels as usize
            && u.len() == n * channels as usize;
        if !sizes_agree {
            return Err(GpuError::Size(format!("grid system of {}x{}: array lengths disagree", sys.width, sys.height)));
        }
        let limit = ctx.device.limits().max_storage_buffer_binding_size as usize;
        if std::mem::size_of_val(u) > limit {
            return Err(GpuError::Size(format!(
                "{} bytes of unknowns exceed the device's storage binding limit of {limit}",
                std::mem::size_of_val(u)
            )));
        }
        let device = &ctx.device;
        let storage = |label: &str, data: &[f32], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytemuck::cast_slice(data), usage })
        };
        let read = wgpu::BufferUsages::STORAGE;
        let right = storage("right", &sys.right, read);
        let down = storage("down", &sys.down, read);
        let inv_diag = storage("inv_diag", &sys.inv_diag, read);
        let rhs = storage("rhs", rhs, read);
        let unknowns = storage("u", u, read | wgpu::BufferUsages::COPY_SRC);
        let scratch = (self.kind == SweepKernel::Tiled).then(|| storage("u scratch", u, read));
        let buffers = [&right, &down, &inv_diag, &rhs, &unknowns, scratch.as_ref().unwrap_or(&unknowns)];
        self.record(ctx, buffers, sys.width, sys.height, channels, sweeps, omega);
        read_blocking(ctx, &unknowns, u)
    }
}

/// The uniform block's mirror, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![
        mirror!(shaders::RED_BLACK, "Params", SweepParams { width, height, parity, channels, omega, _pad0, _pad1, _pad2 }),
        mirror!(shaders::RED_BLACK_TILED, "Params", TiledSweepParams { width, height, parity, channels, omega, half_sweeps, _pad0, _pad1 }),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweeps_spread_over_an_even_number_of_dispatches_of_at_most_the_halo() {
        for sweeps in 0..40 {
            let plan = dispatch_plan(sweeps);
            assert_eq!(plan.iter().sum::<usize>(), 2 * sweeps, "{sweeps} sweeps: {plan:?}");
            assert!(plan.len().is_multiple_of(2) && plan.iter().all(|&h| (1..=HALO).contains(&h)), "{sweeps} sweeps: {plan:?}");
            assert_eq!(plan.len(), (2 * sweeps).div_ceil(HALO).next_multiple_of(2), "{sweeps} sweeps: {plan:?}");
        }
        assert_eq!(dispatch_plan(24), vec![4; 12]);
    }

    #[test]
    fn the_tile_and_halo_are_the_shaders() {
        let source = shaders::RED_BLACK_TILED.1;
        for line in [
            format!("const TILE: u32 = {TILE}u;"),
            format!("const HALO: u32 = {HALO}u;"),
            format!("const SIDE: u32 = {}u;", TILE as usize + 2 * HALO),
        ] {
            assert!(source.contains(&line), "red_black_tiled.wgsl lacks `{line}`");
        }
        assert!(source.contains(&format!("@workgroup_size({TILE}, {TILE})")));
    }
}
