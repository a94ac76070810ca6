// The color initial guess, as dynview-core's LevelViews::blend: the mean of the visible warps
// weighted by view (rank score), the fallback where no view sees. Run once per chunk of
// views (common/chunk.wgsl): view s of the chunk has its pixel i at s * n + i
// (n = width * height).

struct Params {
    width: u32,
    height: u32,
    // Views in this chunk.
    views: u32,
    // FIRST_CHUNK | LAST_CHUNK flags.
    chunk: u32,
    // The weight of each view of the chunk (up to 8).
    view_weights: array<vec4<f32>, 2>,
};

@group(0) @binding(0) var<uniform> params: Params;
// Warped colors of the views (RGB, the chunk's views stacked).
@group(0) @binding(1) var<storage, read> warp_rgb: array<f32>;
// sigma_vis of the views (the chunk's views stacked).
@group(0) @binding(2) var<storage, read> visibility: array<f32>;
// The color where no view sees (RGB).
@group(0) @binding(3) var<storage, read> fallback_rgb: array<f32>;
// Out: the blended color (RGB).
@group(0) @binding(4) var<storage, read_write> color_rgb: array<f32>;
// The weighted sum (RGB) and the sum of weights carried from one chunk to the next (unused
// with one chunk).
@group(0) @binding(5) var<storage, read_write> partial: array<f32>;

fn view_weight(s: u32) -> f32 {
    return params.view_weights[s / 4u][s % 4u];
}

@compute @workgroup_size(8, 8)
fn blend(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var sum = vec3<f32>(0.0);
    var count = 0.0;
    if (!is_first_chunk(params.chunk)) {
        sum = vec3<f32>(partial[i * 4u], partial[i * 4u + 1u], partial[i * 4u + 2u]);
        count = partial[i * 4u + 3u];
    }
    for (var s = 0u; s < params.views; s = s + 1u) {
        if (visibility[s * n + i] > 0.0) {
            let vw = view_weight(s);
            let j = s * n + i;
            let c = vec3<f32>(warp_rgb[j * 3u], warp_rgb[j * 3u + 1u], warp_rgb[j * 3u + 2u]);
            sum = vec3<f32>(sum.x + vw * c.x, sum.y + vw * c.y, sum.z + vw * c.z);
            count = count + vw;
        }
    }
    if (!is_last_chunk(params.chunk)) {
        partial[i * 4u] = sum.x;
        partial[i * 4u + 1u] = sum.y;
        partial[i * 4u + 2u] = sum.z;
        partial[i * 4u + 3u] = count;
        return;
    }
    var out = vec3<f32>(fallback_rgb[i * 3u], fallback_rgb[i * 3u + 1u], fallback_rgb[i * 3u + 2u]);
    if (count > 0.0) {
        out = vec3<f32>(sum.x / count, sum.y / count, sum.z / count);
    }
    color_rgb[i * 3u] = out.x;
    color_rgb[i * 3u + 1u] = out.y;
    color_rgb[i * 3u + 2u] = out.z;
}
