// w_P^s = sigma_vis^s exp(-||P^s - I||^2 / 2 sigma^2) (dynview-core's
// render::weights::projection_weights); stored as -1 where the warp of view s is invalid
// (outside its image), which later passes read as "invalid, weight 0".

// The current color estimate (RGB).
@group(0) @binding(1) var<storage, read> color_rgb: array<f32>;
// Warped colors of the views (RGB, the chunk's views stacked).
@group(0) @binding(2) var<storage, read> warp_rgb: array<f32>;
// sigma_vis of the views (the chunk's views stacked).
@group(0) @binding(3) var<storage, read> visibility: array<f32>;
// 1 where view s's warp lands inside its image, else 0 (the chunk's views stacked).
@group(0) @binding(4) var<storage, read> valid: array<f32>;
// Out: w_P of the views (the chunk's views stacked).
@group(0) @binding(5) var<storage, read_write> w_p: array<f32>;

@compute @workgroup_size(8, 8)
fn projection_weights(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    let color = vec3<f32>(color_rgb[i * 3u], color_rgb[i * 3u + 1u], color_rgb[i * 3u + 2u]);
    for (var s = 0u; s < params.views; s = s + 1u) {
        let j = s * n + i;
        var w = 0.0;
        let vis = visibility[j];
        if (vis > 0.0) {
            let warped = vec3<f32>(warp_rgb[j * 3u], warp_rgb[j * 3u + 1u], warp_rgb[j * 3u + 2u]);
            w = vis * agreement(warped, color, params.sigma);
        }
        if (valid[j] <= 0.0) {
            w = -1.0;
        }
        w_p[j] = w;
    }
}
