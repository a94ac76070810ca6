// Forward warp of a rendered frame (pixels with depth) into a target camera through the pixel
// transfer, following dynview-core's render::sparse::warp_frame term by term: a source pixel
// (x, y) at depth d lands at h = d * M (x, y, 1) + e, divided by h.z. The output bindings and
// `emit` are in common/splat_emit.wgsl.

struct Params {
    // Number of source pixels.
    count: u32,
    // Target image size.
    width: u32,
    height: u32,
    // Source frame width.
    source_width: u32,
    // Rows of the transfer matrix M in xyz (w unused).
    transfer_row0: vec4<f32>,
    transfer_row1: vec4<f32>,
    transfer_row2: vec4<f32>,
    // The transfer's offset e in xyz (w unused).
    transfer_offset: vec4<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
// The source frame's depth, one float per pixel.
@group(0) @binding(1) var<storage, read> source_depth: array<f32>;
// The source frame's color, RGB floats per pixel.
@group(0) @binding(2) var<storage, read> source_rgb: array<f32>;

@compute @workgroup_size(64)
fn project_pixels(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(id, groups);
    if (e >= params.count) {
        return;
    }
    element_target[e] = OUTSIDE;
    let d = source_depth[e];
    if (!(d > 0.0 && d <= MAX_FINITE)) {
        return;
    }
    let x = f32(e % params.source_width);
    let y = f32(e / params.source_width);
    let m0 = params.transfer_row0;
    let m1 = params.transfer_row1;
    let m2 = params.transfer_row2;
    let offset = params.transfer_offset;
    let hz = d * (m2.x * x + m2.y * y + m2.z) + offset.z;
    if (!(hz > 1e-6)) {
        return;
    }
    let hx = d * (m0.x * x + m0.y * y + m0.z) + offset.x;
    let hy = d * (m1.x * x + m1.y * y + m1.z) + offset.y;
    let inv = 1.0 / hz;
    let color = vec3<f32>(source_rgb[e * 3u], source_rgb[e * 3u + 1u], source_rgb[e * 3u + 2u]);
    emit(e, hx * inv, hy * inv, hz, color, params.width, params.height);
}
