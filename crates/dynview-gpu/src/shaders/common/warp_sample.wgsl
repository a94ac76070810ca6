// What warp.wgsl and warp_plate.wgsl share: the uniform block and where a novel pixel samples
// its input, following dynview-core's render::warp (the transfer, the bounds, the bilinear
// taps with edge pixels clamped).

struct Params {
    width: u32,
    height: u32,
    input_width: u32,
    input_height: u32,
    // Relative depth tolerance of the visibility test.
    tolerance: f32,
    offset: u32,
    // The novel view's static mask (warp_plate.wgsl): its size.
    mask_width: u32,
    mask_height: u32,
    // The pixel transfer novel -> input: h = depth * M [x, y, 1] + e (rows of M in xyz).
    m_row0: vec4<f32>,
    m_row1: vec4<f32>,
    m_row2: vec4<f32>,
    e: vec4<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;

// Where novel pixel (x, y) with z-depth d lands in the input: its bilinear taps and weights, the
// continuous position and the depth in the input camera.
struct WarpSample {
    inside: bool,
    i00: u32,
    dx: u32,
    dy: u32,
    tx: f32,
    ty: f32,
    u: f32,
    v: f32,
    hz: f32,
};

fn warp_sample(x: u32, y: u32, d: f32) -> WarpSample {
    var out: WarpSample;
    out.inside = false;
    let fx = f32(x);
    let fy = f32(y);
    // As RowTransfer: the row's y folded in first, then the x terms.
    let base = vec3<f32>(params.m_row0.y * fy + params.m_row0.z, params.m_row1.y * fy + params.m_row1.z, params.m_row2.y * fy + params.m_row2.z);
    let hz = d * (params.m_row2.x * fx + base.z) + params.e.z;
    if (!(hz > 1e-6)) {
        return out;
    }
    let inv = 1.0 / hz;
    let u = (d * (params.m_row0.x * fx + base.x) + params.e.x) * inv;
    let v = (d * (params.m_row1.x * fx + base.y) + params.e.y) * inv;
    let wf = f32(params.input_width);
    let hf = f32(params.input_height);
    if (!(u >= -0.5 && v >= -0.5 && u < wf - 0.5 && v < hf - 0.5)) {
        return out;
    }
    let uc = clamp(u, 0.0, wf - 1.0);
    let vc = clamp(v, 0.0, hf - 1.0);
    let x0 = u32(uc);
    let y0 = u32(vc);
    out.tx = uc - f32(x0);
    out.ty = vc - f32(y0);
    out.dx = 0u;
    if (x0 + 1u < params.input_width) {
        out.dx = 1u;
    }
    out.dy = 0u;
    if (y0 + 1u < params.input_height) {
        out.dy = params.input_width;
    }
    out.i00 = y0 * params.input_width + x0;
    out.u = u;
    out.v = v;
    out.hz = hz;
    out.inside = true;
    return out;
}
