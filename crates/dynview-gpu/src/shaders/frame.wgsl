// Per-level pieces of the frame loop, following dynview-core's render::frame and
// render::weights term by term: the color initial guess (blend of the visible warps weighted by
// rank score), w_T, and the packing of the temporal terms for assemble.wgsl.

struct Params {
    width: u32,
    height: u32,
    views: u32,
    // temporal_terms: 1 when lambda_T is scaled by the sparse coverage.
    coverage_scaling: u32,
    sigma: f32,
    lambda_t: f32,
    _pad0: u32,
    _pad1: u32,
    // blend: the weight of each view (up to 8).
    view_weights: array<vec4<f32>, 2>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> in1: array<f32>;
@group(0) @binding(2) var<storage, read> in2: array<f32>;
@group(0) @binding(3) var<storage, read> in3: array<f32>;
@group(0) @binding(4) var<storage, read> in4: array<f32>;
@group(0) @binding(5) var<storage, read_write> out1: array<f32>;
@group(0) @binding(6) var<storage, read_write> out2: array<f32>;

fn rgb1(i: u32) -> vec3<f32> {
    return vec3<f32>(in1[i * 3u], in1[i * 3u + 1u], in1[i * 3u + 2u]);
}

fn view_weight(s: u32) -> f32 {
    return params.view_weights[s / 4u][s % 4u];
}

// Mean of the visible warps weighted by view; the fallback where no view sees.
// in1 = warp colors (packed), in2 = visibility (packed), in3 = fallback RGB. out1 = color.
@compute @workgroup_size(8, 8)
fn blend(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var sum = vec3<f32>(0.0);
    var count = 0.0;
    for (var s = 0u; s < params.views; s = s + 1u) {
        if (in2[s * n + i] > 0.0) {
            let vw = view_weight(s);
            let c = rgb1(s * n + i);
            sum = vec3<f32>(sum.x + vw * c.x, sum.y + vw * c.y, sum.z + vw * c.z);
            count = count + vw;
        }
    }
    var out = vec3<f32>(in3[i * 3u], in3[i * 3u + 1u], in3[i * 3u + 2u]);
    if (count > 0.0) {
        out = vec3<f32>(sum.x / count, sum.y / count, sum.z / count);
    }
    out1[i * 3u] = out.x;
    out1[i * 3u + 1u] = out.y;
    out1[i * 3u + 2u] = out.z;
}

fn agreement(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let d = a - b;
    let d2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
    return exp(-d2 / (2.0 * params.sigma * params.sigma));
}

// w_T: the mean agreement of the previous frame's warped color with the valid warps; 0 where
// the previous frame does not cover the pixel or no view is valid.
// in1 = warp colors (packed), in2 = validity (packed), in3 = previous color, in4 = previous
// mask. out1 = w_T.
@compute @workgroup_size(8, 8)
fn temporal_weights(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var w = 0.0;
    if (in4[i] > 0.0) {
        let previous = vec3<f32>(in3[i * 3u], in3[i * 3u + 1u], in3[i * 3u + 2u]);
        var sum = 0.0;
        var count = 0u;
        for (var s = 0u; s < params.views; s = s + 1u) {
            if (in2[s * n + i] > 0.0) {
                sum = sum + agreement(previous, rgb1(s * n + i));
                count = count + 1u;
            }
        }
        if (count > 0u) {
            w = sum / f32(count);
        }
    }
    out1[i] = w;
}

// The temporal terms as assemble.wgsl takes them: (lambda_T w_T, previous depth) and
// (lambda_T w_T, previous RGB), lambda_T scaled by the sparse coverage when asked.
// in1 = w_T, in2 = previous depth, in3 = previous color, in4 = coverage counters (u32 bits:
// [1] = covered pixels after the consistency filter). out1 = depth terms, out2 = color terms.
@compute @workgroup_size(8, 8)
fn temporal_terms(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var lambda_t = params.lambda_t;
    if (params.coverage_scaling != 0u) {
        lambda_t = params.lambda_t * f32(bitcast<u32>(in4[1])) / f32(max(n, 1u));
    }
    let t = lambda_t * in1[i];
    out1[i * 2u] = t;
    out1[i * 2u + 1u] = in2[i];
    out2[i * 4u] = t;
    out2[i * 4u + 1u] = in3[i * 3u];
    out2[i * 4u + 2u] = in3[i * 3u + 1u];
    out2[i * 4u + 3u] = in3[i * 3u + 2u];
}

// The sparse maps' color and mask as one RGB+mask image for assemble.wgsl.
// in1 = color, in2 = mask. out1 = RGBA.
@compute @workgroup_size(8, 8)
fn pack_sparse(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let i = id.y * params.width + id.x;
    out1[i * 4u] = in1[i * 3u];
    out1[i * 4u + 1u] = in1[i * 3u + 1u];
    out1[i * 4u + 2u] = in1[i * 3u + 2u];
    out1[i * 4u + 3u] = in2[i];
}
