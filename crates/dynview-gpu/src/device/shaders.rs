//! The crate's WGSL, composed, and compiling it on a device: a shader is its own file in
//! `src/shaders/` after the shared code it needs from `src/shaders/common/`, joined at compile
//! time. The WGSL is the single source of truth for the uniform blocks; the Rust mirrors are
//! checked against naga's reflection of it (`shader_layout.rs`, `src/layout_tests.rs`).

/// A shader: its name (its own file under `shaders/`) and its composed source.
pub(crate) type Shader = (&'static str, &'static str);

/// The sources of `src/shaders/` files, joined in order (shared code first).
macro_rules! wgsl {
    ($($file:literal),+ $(,)?) => {
        concat!($(include_str!(concat!("../shaders/", $file))),+)
    };
}

/// `(name, composed source)` of one shader: the shared files, then the shader's own file.
macro_rules! shader {
    ($file:literal $(, $common:literal)* $(,)?) => {
        ($file, wgsl!($($common,)* $file))
    };
}

/// Red-black sweeps of a grid system, one colour per dispatch.
pub(crate) const RED_BLACK: Shader = shader!("red_black.wgsl", "common/grid_system.wgsl");
/// Red-black sweeps of a grid system, several colours per dispatch on workgroup-local tiles.
pub(crate) const RED_BLACK_TILED: Shader = shader!("red_black_tiled.wgsl", "common/grid_system.wgsl");
/// 2x2 box downsampling and bilinear upsampling.
pub(crate) const PYRAMID: Shader = shader!("pyramid.wgsl", "common/bilinear.wgsl");
/// Push-pull hole filling: the pull (premultiplied 2x2 sums).
pub(crate) const PUSHPULL_PULL: Shader = shader!("pushpull_pull.wgsl");
/// Push-pull hole filling: the push (the coarser fill where a level is unknown).
pub(crate) const PUSHPULL_PUSH: Shader = shader!("pushpull_push.wgsl", "common/bilinear.wgsl");
/// Backward warps of the input views and their visibility.
pub(crate) const WARP: Shader =
    shader!("warp.wgsl", "common/warp_sample.wgsl", "common/float_bits.wgsl", "common/outside.wgsl", "common/linear.wgsl");
/// The background plates' colors where the novel view shows the static scene.
pub(crate) const WARP_PLATE: Shader = shader!("warp_plate.wgsl", "common/warp_sample.wgsl", "common/float_bits.wgsl");
/// `w_P^s` of every view.
pub(crate) const PROJECTION_WEIGHTS: Shader = shader!("assemble/projection_weights.wgsl", "assemble/params.wgsl", "common/agreement.wgsl");
/// `w_D` and the sparse attachment `lambda_PC w_H`.
pub(crate) const DEPTH_WEIGHTS: Shader =
    shader!("assemble/depth_weights.wgsl", "assemble/params.wgsl", "common/agreement.wgsl", "common/chunk.wgsl");
/// The depth system.
pub(crate) const DEPTH_SYSTEM: Shader = shader!("assemble/depth_system.wgsl", "assemble/params.wgsl", "common/float_bits.wgsl");
/// The plane's pull per pixel from the points' support.
pub(crate) const PLANE_SUPPORT: Shader = shader!("assemble/plane_support.wgsl");
/// The rank preference of the color energy where points are scarce.
pub(crate) const RANK_PREFERENCE: Shader = shader!("assemble/rank_preference.wgsl");
/// The color system.
pub(crate) const COLOR_SYSTEM: Shader = shader!("assemble/color_system.wgsl", "assemble/params.wgsl", "common/chunk.wgsl");
/// The view weight the viewer shows, `sum_s w_P^s`.
pub(crate) const VIEW_WEIGHT: Shader = shader!("assemble/view_weight.wgsl", "assemble/params.wgsl", "common/chunk.wgsl");
/// Projection of the sparse cloud's points into a camera.
pub(crate) const SPLAT_POINTS: Shader = shader!("splat_points.wgsl", "common/outside.wgsl", "common/splat_emit.wgsl", "common/linear.wgsl");
/// Forward warp of a rendered frame's pixels into a camera.
pub(crate) const SPLAT_PIXELS: Shader =
    shader!("splat_pixels.wgsl", "common/float_bits.wgsl", "common/outside.wgsl", "common/splat_emit.wgsl", "common/linear.wgsl");
/// The z-buffer resolve of a splat.
pub(crate) const SPLAT_RESOLVE: Shader =
    shader!("splat_resolve.wgsl", "common/float_bits.wgsl", "common/outside.wgsl", "common/linear.wgsl");
/// The sparse samples attached over their footprints.
pub(crate) const SPLAT_FOOTPRINT: Shader = shader!("splat_footprint.wgsl");
/// The plates' static mask from the own and static points' splats.
pub(crate) const STATIC_MASK: Shader = shader!("static_mask.wgsl", "common/float_bits.wgsl");
/// The sparse maps' color and mask as one RGBA image.
pub(crate) const SPLAT_PACK: Shader = shader!("splat_pack.wgsl");
/// The sparse consistency filter.
pub(crate) const CONSISTENCY: Shader = shader!("consistency.wgsl", "common/float_bits.wgsl");
/// The color initial guess: the weighted blend of the visible warps.
pub(crate) const BLEND: Shader = shader!("blend.wgsl", "common/chunk.wgsl");
/// `w_T`.
pub(crate) const TEMPORAL_WEIGHTS: Shader = shader!("temporal_weights.wgsl", "common/agreement.wgsl", "common/chunk.wgsl");
/// The temporal terms of both systems.
pub(crate) const TEMPORAL_TERMS: Shader = shader!("temporal_terms.wgsl");
/// The range of the false-color depth display.
pub(crate) const DEPTH_RANGE: Shader = shader!("depth_range.wgsl", "common/float_bits.wgsl");
/// Zeros over a buffer (a reused image).
pub(crate) const ZERO: Shader = shader!("zero.wgsl", "common/linear.wgsl");
/// Drawing a frame into a render target.
pub(crate) const DISPLAY: Shader = shader!("display.wgsl", "common/float_bits.wgsl");

/// Every WGSL shader of the crate as `(name, composed source)` (validated by naga in the tests).
pub const SHADERS: &[(&str, &str)] = &[
    RED_BLACK,
    RED_BLACK_TILED,
    PYRAMID,
    PUSHPULL_PULL,
    PUSHPULL_PUSH,
    WARP,
    WARP_PLATE,
    PROJECTION_WEIGHTS,
    DEPTH_WEIGHTS,
    DEPTH_SYSTEM,
    PLANE_SUPPORT,
    RANK_PREFERENCE,
    COLOR_SYSTEM,
    VIEW_WEIGHT,
    SPLAT_POINTS,
    SPLAT_PIXELS,
    SPLAT_RESOLVE,
    SPLAT_PACK,
    SPLAT_FOOTPRINT,
    STATIC_MASK,
    CONSISTENCY,
    BLEND,
    TEMPORAL_WEIGHTS,
    TEMPORAL_TERMS,
    DEPTH_RANGE,
    ZERO,
    DISPLAY,
];

/// Compiles `shader` on `device`.
pub(crate) fn module(device: &wgpu::Device, (name, source): Shader) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(source.into()) })
}
