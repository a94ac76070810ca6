// Push-pull hole filling, the pull half (the push is pushpull_push.wgsl), following
// dynview-core's render::pushpull::fill term by term: premultiplied 2x2 sums from a finer level
// down to a coarser one, weights saturating at 1. Values are flat arrays of `channels` floats per
// pixel; weights one float.

struct Dims {
    // The level read.
    fine_width: u32,
    fine_height: u32,
    // The level written (premultiply: the same size as the level read).
    coarse_width: u32,
    coarse_height: u32,
    channels: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<uniform> dims: Dims;
// Premultiply: the image and its weights. Pull: the finer level's premultiplied values, weights.
@group(0) @binding(1) var<storage, read> fine_values: array<f32>;
@group(0) @binding(2) var<storage, read> fine_weights: array<f32>;
@group(0) @binding(3) var<storage, read_write> coarse_values: array<f32>;
@group(0) @binding(4) var<storage, read_write> coarse_weights: array<f32>;

// The finest level of the pull: coarse_values = fine_values * fine_weights,
// coarse_weights = fine_weights, pixel for pixel.
@compute @workgroup_size(8, 8)
fn premultiply(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= dims.fine_width || id.y >= dims.fine_height) {
        return;
    }
    let n = dims.channels;
    let i = id.y * dims.fine_width + id.x;
    for (var c = 0u; c < n; c = c + 1u) {
        // 0 where unknown, whatever the value there (an infinite depth must not become NaN).
        coarse_values[i * n + c] = select(0.0, fine_values[i * n + c] * fine_weights[i], fine_weights[i] > 0.0);
    }
    coarse_weights[i] = fine_weights[i];
}

@compute @workgroup_size(8, 8)
fn pull(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= dims.coarse_width || id.y >= dims.coarse_height) {
        return;
    }
    let n = dims.channels;
    var sw = 0.0;
    var sv = vec4<f32>(0.0);
    for (var k = 0u; k < 4u; k = k + 1u) {
        let sx = 2u * id.x + (k & 1u);
        let sy = 2u * id.y + (k >> 1u);
        if (sx < dims.fine_width && sy < dims.fine_height) {
            let j = sy * dims.fine_width + sx;
            for (var c = 0u; c < n; c = c + 1u) {
                sv[c] = sv[c] + fine_values[j * n + c];
            }
            sw = sw + fine_weights[j];
        }
    }
    // Saturate: a coarse pixel with full support counts as known.
    var scale = 1.0;
    if (sw > 1.0) {
        scale = 1.0 / sw;
    }
    let i = id.y * dims.coarse_width + id.x;
    for (var c = 0u; c < n; c = c + 1u) {
        coarse_values[i * n + c] = sv[c] * scale;
    }
    coarse_weights[i] = min(sw, 1.0);
}
