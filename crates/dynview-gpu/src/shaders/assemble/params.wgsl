// The uniform block of the weights and the assembly of the depth and color systems
// (assemble/*.wgsl), which follow dynview-core's render::weights and render::solve term by
// term; the systems feed red_black.wgsl. The kernels run once per chunk of views
// (common/chunk.wgsl): view s of the chunk has its pixel i at s * n + i (n = width * height).

struct Params {
    width: u32,
    height: u32,
    // Views in this chunk.
    views: u32,
    // FIRST_CHUNK | LAST_CHUNK flags (the kernels that sum over the views).
    chunk: u32,
    sigma: f32,
    lambda_pc: f32,
    lambda_p: f32,
    lambda_g: f32,
    gradient_unit: f32,
    eps_gradient: f32,
    eps_visibility: f32,
    w_d_min: f32,
    w_d_max: f32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
