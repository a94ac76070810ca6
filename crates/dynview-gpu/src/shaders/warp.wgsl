// Backward warp of one input view into the novel view with the current depth, and visibility
// sigma_vis by scattering the novel pixels' depths into a depth buffer the size of the input
// image (atomic min), following dynview-core's render::warp term by term.
//
// Entry points, in order: clear_zbuf (over input pixels), warp (over novel pixels),
// visible (over novel pixels). Color, visibility and validity are written at `offset` into
// buffers that stack the views (the view's first pixel in its chunk of views, views.rs).
// The uniform block and the sample position are common/warp_sample.wgsl's, shared with
// warp_plate.wgsl.

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
    let at = warp_sample(x, y, d);
    if (!at.inside) {
        return;
    }
    for (var k = 0u; k < 3u; k = k + 1u) {
        let a = pixel(at.i00, k);
        let b = pixel(at.i00 + at.dx, k);
        let c = pixel(at.i00 + at.dy, k);
        let e = pixel(at.i00 + at.dy + at.dx, k);
        let top = a + (b - a) * at.tx;
        let bottom = c + (e - c) * at.tx;
        color[o * 3u + k] = top + (bottom - top) * at.ty;
    }
    let u = at.u;
    let v = at.v;
    let hz = at.hz;
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
