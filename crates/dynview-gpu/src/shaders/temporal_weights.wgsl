// w_T, as dynview-core's render::weights::temporal_weights: the mean agreement of the previous
// frame's warped color with the valid warps; 0 where the previous frame does not cover the
// pixel or no view is valid. Views are packed: view s's pixel i is at s * n + i.

struct Params {
    width: u32,
    height: u32,
    views: u32,
    sigma: f32,
};

@group(0) @binding(0) var<uniform> params: Params;
// Warped colors of the views (RGB, packed).
@group(0) @binding(1) var<storage, read> warp_rgb: array<f32>;
// 1 where view s's warp lands inside its image, else 0 (packed).
@group(0) @binding(2) var<storage, read> valid: array<f32>;
// The previous frame splatted into this view: color (RGB) and mask.
@group(0) @binding(3) var<storage, read> previous_rgb: array<f32>;
@group(0) @binding(4) var<storage, read> previous_mask: array<f32>;
// Out: w_T.
@group(0) @binding(5) var<storage, read_write> w_t: array<f32>;

@compute @workgroup_size(8, 8)
fn temporal_weights(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var w = 0.0;
    if (previous_mask[i] > 0.0) {
        let previous = vec3<f32>(previous_rgb[i * 3u], previous_rgb[i * 3u + 1u], previous_rgb[i * 3u + 2u]);
        var sum = 0.0;
        var count = 0u;
        for (var s = 0u; s < params.views; s = s + 1u) {
            let j = s * n + i;
            if (valid[j] > 0.0) {
                let warped = vec3<f32>(warp_rgb[j * 3u], warp_rgb[j * 3u + 1u], warp_rgb[j * 3u + 2u]);
                sum = sum + agreement(previous, warped, params.sigma);
                count = count + 1u;
            }
        }
        if (count > 0u) {
            w = sum / f32(count);
        }
    }
    w_t[i] = w;
}
