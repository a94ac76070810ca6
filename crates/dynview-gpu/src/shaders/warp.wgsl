// Backward warp of one input view into the novel view with the current depth, and visibility
// sigma_vis by scattering the novel pixels' depths into a depth buffer the size of the input
// image (atomic min), following dynview-core's render::warp term by term.
//
// Entry points, in order: clear_zbuf (over input pixels), warp (over novel pixels),
// visible (over novel pixels). Color, visibility and validity are written at `offset` into
// buffers that stack the views (the view's first pixel in its chunk of views, views.rs).

struct Params {
    width: u32,
    height: u32,
    input_width: u32,
    input_height: u32,
    // Relative depth tolerance of the visibility test.
    tolerance: f32,
    offset: u32,
    _pad1: u32,
    _pad2: u32,
    // The pixel transfer novel -> input: h = depth * M [x, y, 1] + e (rows of M in xyz).
    m_row0: vec4<f32>,
    m_row1: vec4<f32>,
    m_row2: vec4<f32>,
    e: vec4<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
// Novel-view z-depth.
@group(0) @binding(1) var<storage, read> depth: array<f32>;
// The input frame, RGB floats.
@group(0) @binding(2) var<storage, read> input: array<f32>;
// Outputs per novel pixel: warped color (RGB floats, packed), nearest input pixel, depth in the
// input camera, visibility (packed).
@group(0) @binding(3) var<storage, read_write> color: array<f32>;
@group(0) @binding(4) var<storage, read_write> target_pixel: array<u32>;
@group(0) @binding(5) var<storage, read_write> depth_in_input: array<f32>;
@group(0) @binding(6) var<storage, read_write> visibility: array<f32>;
// Per input pixel: the nearest depth landing there, as f32 bits (positive floats order as
// their bits).
@group(0) @binding(7) var<storage, read_write> zbuf: array<atomic<u32>>;
// 1 where the novel pixel lands inside the input image, else 0 (packed).
@group(0) @binding(8) var<storage, read_write> valid: array<f32>;

@compute @workgroup_size(64)
fn clear_zbuf(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(id, groups);
    if (i < params.input_width * params.input_height) {
        atomicStore(&zbuf[i], INFINITY_BITS);
    }
}

fn pixel(i: u32, k: u32) -> f32 {
    return input[i * 3u + k];
}

@compute @workgroup_size(8, 8)
fn warp(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if (x >= params.width || y >= params.height) {
        return;
    }
    let i = y * params.width + x;
    let o = params.offset + i;
    color[o * 3u] = 0.0;
    color[o * 3u + 1u] = 0.0;
    color[o * 3u + 2u] = 0.0;
    target_pixel[i] = OUTSIDE;
    depth_in_input[i] = 0.0;
    let d = depth[i];
    if (!(d > 0.0 && d <= MAX_FINITE)) {
        return;
    }
    let fx = f32(x);
    let fy = f32(y);
    // As RowTransfer: the row's y folded in first, then the x terms.
    let base = vec3<f32>(params.m_row0.y * fy + params.m_row0.z, params.m_row1.y * fy + params.m_row1.z, params.m_row2.y * fy + params.m_row2.z);
    let hz = d * (params.m_row2.x * fx + base.z) + params.e.z;
    if (!(hz > 1e-6)) {
        return;
    }
    let inv = 1.0 / hz;
    let u = (d * (params.m_row0.x * fx + base.x) + params.e.x) * inv;
    let v = (d * (params.m_row1.x * fx + base.y) + params.e.y) * inv;
    let wf = f32(params.input_width);
    let hf = f32(params.input_height);
    if (!(u >= -0.5 && v >= -0.5 && u < wf - 0.5 && v < hf - 0.5)) {
        return;
    }
    let uc = clamp(u, 0.0, wf - 1.0);
    let vc = clamp(v, 0.0, hf - 1.0);
    let x0 = u32(uc);
    let y0 = u32(vc);
    let tx = uc - f32(x0);
    let ty = vc - f32(y0);
    var dx = 0u;
    if (x0 + 1u < params.input_width) {
        dx = 1u;
    }
    var dy = 0u;
    if (y0 + 1u < params.input_height) {
        dy = params.input_width;
    }
    let i00 = y0 * params.input_width + x0;
    for (var k = 0u; k < 3u; k = k + 1u) {
        let a = pixel(i00, k);
        let b = pixel(i00 + dx, k);
        let c = pixel(i00 + dy, k);
        let e = pixel(i00 + dy + dx, k);
        let top = a + (b - a) * tx;
        let bottom = c + (e - c) * tx;
        color[o * 3u + k] = top + (bottom - top) * ty;
    }
    let ui = min(u32(u + 0.5), params.input_width - 1u);
    let vi = min(u32(v + 0.5), params.input_height - 1u);
    let t = vi * params.input_width + ui;
    target_pixel[i] = t;
    depth_in_input[i] = hz;
    atomicMin(&zbuf[t], bitcast<u32>(hz));
}

@compute @workgroup_size(8, 8)
fn visible(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let i = id.y * params.width + id.x;
    let t = target_pixel[i];
    var vis = 0.0;
    if (t != OUTSIDE && depth_in_input[i] <= bitcast<f32>(atomicLoad(&zbuf[t])) * (1.0 + params.tolerance)) {
        vis = 1.0;
    }
    visibility[params.offset + i] = vis;
    valid[params.offset + i] = select(0.0, 1.0, t != OUTSIDE);
}
