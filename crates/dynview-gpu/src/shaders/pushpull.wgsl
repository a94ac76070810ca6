// Push-pull hole filling, following dynview-core's render::pushpull::fill term by term.
// Pull: premultiplied 2x2 sums down to one pixel, weights saturating at 1. Push: from coarse to
// fine, each level keeps its known share and takes the bilinear upsampled coarser fill (common/bilinear.wgsl) for the
// missing share. Values are flat arrays of `channels` floats per pixel; weights one float.

struct Dims {
    // The level written (pull: the coarse one; push: the fine one).
    width: u32,
    height: u32,
    // The other level (pull: the finer source; push: the coarser fill).
    other_width: u32,
    other_height: u32,
    channels: u32,
    // Push: coarse / fine size ratios, computed on the host as the CPU path does.
    scale_x: f32,
    scale_y: f32,
    _pad: u32,
    // Top level: the value where nothing at all is known.
    fallback: vec4<f32>,
};

@group(0) @binding(0) var<uniform> dims: Dims;
// Pull: the finer level's premultiplied values and weights. Push: this level's.
@group(0) @binding(1) var<storage, read> values: array<f32>;
@group(0) @binding(2) var<storage, read> weights: array<f32>;
// Push: the coarser level's fill. Premultiply, pull and top: unused (bound to the weights).
@group(0) @binding(3) var<storage, read> coarse_fill: array<f32>;
@group(0) @binding(4) var<storage, read_write> out_values: array<f32>;
@group(0) @binding(5) var<storage, read_write> out_weights: array<f32>;

// out_values = values * weights (the finest level of the pull), out_weights = weights.
@compute @workgroup_size(8, 8)
fn premultiply(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= dims.width || id.y >= dims.height) {
        return;
    }
    let i = id.y * dims.width + id.x;
    for (var c = 0u; c < dims.channels; c = c + 1u) {
        // 0 where unknown, whatever the value there (an infinite depth must not become NaN).
        out_values[i * dims.channels + c] = select(0.0, values[i * dims.channels + c] * weights[i], weights[i] > 0.0);
    }
    out_weights[i] = weights[i];
}

@compute @workgroup_size(8, 8)
fn pull(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= dims.width || id.y >= dims.height) {
        return;
    }
    let n = dims.channels;
    var sw = 0.0;
    var sv = vec4<f32>(0.0);
    for (var k = 0u; k < 4u; k = k + 1u) {
        let sx = 2u * id.x + (k & 1u);
        let sy = 2u * id.y + (k >> 1u);
        if (sx < dims.other_width && sy < dims.other_height) {
            let j = sy * dims.other_width + sx;
            for (var c = 0u; c < n; c = c + 1u) {
                sv[c] = sv[c] + values[j * n + c];
            }
            sw = sw + weights[j];
        }
    }
    // Saturate: a coarse pixel with full support counts as known.
    var scale = 1.0;
    if (sw > 1.0) {
        scale = 1.0 / sw;
    }
    let i = id.y * dims.width + id.x;
    for (var c = 0u; c < n; c = c + 1u) {
        out_values[i * n + c] = sv[c] * scale;
    }
    out_weights[i] = min(sw, 1.0);
}

// The 1x1 top level: its mean where anything is known, else the fallback.
@compute @workgroup_size(1)
fn top(@builtin(global_invocation_id) id: vec3<u32>) {
    for (var c = 0u; c < dims.channels; c = c + 1u) {
        if (weights[0] > 0.0) {
            out_values[c] = values[c] * (1.0 / weights[0]);
        } else {
            out_values[c] = dims.fallback[c];
        }
    }
}

fn coarse_at(x: u32, y: u32, c: u32) -> f32 {
    return coarse_fill[(y * dims.other_width + x) * dims.channels + c];
}

@compute @workgroup_size(8, 8)
fn push(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= dims.width || id.y >= dims.height) {
        return;
    }
    let t = bilinear_taps(id.x, id.y, vec2<f32>(dims.scale_x, dims.scale_y), vec2<u32>(dims.other_width, dims.other_height));
    let i = id.y * dims.width + id.x;
    let w = weights[i];
    let wi = min(w, 1.0);
    for (var c = 0u; c < dims.channels; c = c + 1u) {
        let up = bilinear_mix(t, coarse_at(t.x0, t.y0, c), coarse_at(t.x1, t.y0, c), coarse_at(t.x0, t.y1, c), coarse_at(t.x1, t.y1, c));
        let v = values[i * dims.channels + c];
        var result: f32;
        if (w >= 1.0) {
            result = v * (1.0 / max(w, 1.0));
        } else {
            result = v + up * (1.0 - wi);
        }
        out_values[i * dims.channels + c] = result;
    }
}
