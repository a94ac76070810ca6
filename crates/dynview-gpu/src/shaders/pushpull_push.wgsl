// Push-pull hole filling, the push half (the pull is pushpull_pull.wgsl), following
// dynview-core's render::pushpull::fill term by term: from the 1x1 top down, each level keeps
// its known share and takes the bilinear upsampled coarser fill (common/bilinear.wgsl) for the
// missing share. Values are flat arrays of `channels` floats per pixel; weights one float.

struct Dims {
    // The level filled.
    fine_width: u32,
    fine_height: u32,
    // The coarser level's fill.
    coarse_width: u32,
    coarse_height: u32,
    channels: u32,
    // Coarse / fine size ratios, computed on the host as the CPU path does.
    scale_x: f32,
    scale_y: f32,
    _pad: u32,
    // Top: the value where nothing at all is known.
    fallback: vec4<f32>,
};

@group(0) @binding(0) var<uniform> dims: Dims;
// The pull's premultiplied values and weights of the level filled.
@group(0) @binding(1) var<storage, read> fine_values: array<f32>;
@group(0) @binding(2) var<storage, read> fine_weights: array<f32>;
// The coarser level's fill (top: none; bound to any buffer, unused).
@group(0) @binding(3) var<storage, read> coarse_fill: array<f32>;
@group(0) @binding(4) var<storage, read_write> fine_fill: array<f32>;

// The 1x1 top level: its mean where anything is known, else the fallback.
@compute @workgroup_size(1)
fn top(@builtin(global_invocation_id) id: vec3<u32>) {
    for (var c = 0u; c < dims.channels; c = c + 1u) {
        if (fine_weights[0] > 0.0) {
            fine_fill[c] = fine_values[c] * (1.0 / fine_weights[0]);
        } else {
            fine_fill[c] = dims.fallback[c];
        }
    }
}

fn coarse_at(x: u32, y: u32, c: u32) -> f32 {
    return coarse_fill[(y * dims.coarse_width + x) * dims.channels + c];
}

@compute @workgroup_size(8, 8)
fn push(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= dims.fine_width || id.y >= dims.fine_height) {
        return;
    }
    let t = bilinear_taps(id.x, id.y, vec2<f32>(dims.scale_x, dims.scale_y), vec2<u32>(dims.coarse_width, dims.coarse_height));
    let n = dims.channels;
    let i = id.y * dims.fine_width + id.x;
    let w = fine_weights[i];
    let wi = min(w, 1.0);
    for (var c = 0u; c < n; c = c + 1u) {
        let up = bilinear_mix(t, coarse_at(t.x0, t.y0, c), coarse_at(t.x1, t.y0, c), coarse_at(t.x0, t.y1, c), coarse_at(t.x1, t.y1, c));
        let v = fine_values[i * n + c];
        var result: f32;
        if (w >= 1.0) {
            result = v * (1.0 / max(w, 1.0));
        } else {
            result = v + up * (1.0 - wi);
        }
        fine_fill[i * n + c] = result;
    }
}
