// w_T, as dynview-core's render::weights::temporal_weights: the mean agreement of the previous
// frame's warped color with the valid warps; 0 where the previous frame does not cover the
// pixel or no view is valid. Run once per chunk of views (common/chunk.wgsl): view s of the
// chunk has its pixel i at s * n + i.

struct Params {
    width: u32,
    height: u32,
    // Views in this chunk.
    views: u32,
    sigma: f32,
    // FIRST_CHUNK | LAST_CHUNK flags.
    chunk: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
// Warped colors of the views (RGB, the chunk's views stacked).
@group(0) @binding(1) var<storage, read> warp_rgb: array<f32>;
// 1 where view s's warp lands inside its image, else 0 (the chunk's views stacked).
@group(0) @binding(2) var<storage, read> valid: array<f32>;
// The previous frame splatted into this view: color (RGB) and mask.
@group(0) @binding(3) var<storage, read> previous_rgb: array<f32>;
@group(0) @binding(4) var<storage, read> previous_mask: array<f32>;
// Out: w_T.
@group(0) @binding(5) var<storage, read_write> w_t: array<f32>;
// The sum of agreements and the count of valid views carried from one chunk to the next
// (unused with one chunk).
@group(0) @binding(6) var<storage, read_write> partial: array<f32>;

@compute @workgroup_size(8, 8)
fn temporal_weights(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var sum = 0.0;
    var count = 0.0;
    if (!is_first_chunk(params.chunk)) {
        sum = partial[i * 2u];
        count = partial[i * 2u + 1u];
    }
    let covered = previous_mask[i] > 0.0;
    if (covered) {
        let previous = vec3<f32>(previous_rgb[i * 3u], previous_rgb[i * 3u + 1u], previous_rgb[i * 3u + 2u]);
        for (var s = 0u; s < params.views; s = s + 1u) {
            let j = s * n + i;
            if (valid[j] > 0.0) {
                let warped = vec3<f32>(warp_rgb[j * 3u], warp_rgb[j * 3u + 1u], warp_rgb[j * 3u + 2u]);
                sum = sum + agreement(previous, warped, params.sigma);
                count = count + 1.0;
            }
        }
    }
    if (!is_last_chunk(params.chunk)) {
        partial[i * 2u] = sum;
        partial[i * 2u + 1u] = count;
        return;
    }
    var w = 0.0;
    if (covered && count > 0.0) {
        w = sum / count;
    }
    w_t[i] = w;
}
