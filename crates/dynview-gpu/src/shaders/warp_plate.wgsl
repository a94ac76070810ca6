// The background plates where the novel view shows the static scene (issue 33), following
// dynview-core's render::levels: after warp.wgsl has written a view's warped frame, each novel
// pixel that the static mask marks as static (the mask at the view's size or smaller, sampled at the nearest
// pixel as render::plates::mask_at) and that lands inside the input takes the same bilinear
// sample of the view's plate instead: all of it where the mask is 1, mixed with the frame's by
// the mask's value on a feathered edge (render::plates::mixed). The uniform block is
// warp.wgsl's (common/warp_sample.wgsl).

// Novel-view z-depth.
@group(0) @binding(1) var<storage, read> depth: array<f32>;
// The view's background plate, RGB floats, the input's size.
@group(0) @binding(2) var<storage, read> plate: array<f32>;
// The novel view's static mask, at its size or smaller (1: the static scene), `mask_width x mask_height`.
@group(0) @binding(3) var<storage, read> static_mask: array<f32>;
// Warped colors of the stacked views (RGB floats, the view at `offset`).
@group(0) @binding(4) var<storage, read_write> color: array<f32>;

@compute @workgroup_size(8, 8)
fn warp_plate(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if (x >= params.width || y >= params.height) {
        return;
    }
    let m = (y * params.mask_height / params.height) * params.mask_width + x * params.mask_width / params.width;
    let stat = static_mask[m];
    if (!(stat > 0.0)) {
        return;
    }
    let i = y * params.width + x;
    let d = depth[i];
    if (!(d > 0.0 && d <= MAX_FINITE)) {
        return;
    }
    let at = warp_sample(x, y, d);
    if (!at.inside) {
        return;
    }
    let o = params.offset + i;
    for (var k = 0u; k < 3u; k = k + 1u) {
        let a = plate[at.i00 * 3u + k];
        let b = plate[(at.i00 + at.dx) * 3u + k];
        let c = plate[(at.i00 + at.dy) * 3u + k];
        let e = plate[(at.i00 + at.dy + at.dx) * 3u + k];
        let top = a + (b - a) * at.tx;
        let bottom = c + (e - c) * at.tx;
        let sample = top + (bottom - top) * at.ty;
        if (stat >= 1.0) {
            color[o * 3u + k] = sample;
        } else {
            let frame = color[o * 3u + k];
            color[o * 3u + k] = frame + (sample - frame) * stat;
        }
    }
}
