// w_D = clamp(sum w_P / ((|grad (u I)|^2 + eps_g)(sum sigma_vis + eps_v)), w_d_min, w_d_max)
// (dynview-core's render::weights::depth_smoothness_weights) and the sparse attachment
// lambda_PC w_H (w_H the agreement of the sparse color where a point landed,
// render::weights::sparse_weights).

// The current color estimate (RGB).
@group(0) @binding(1) var<storage, read> color_rgb: array<f32>;
// w_P of the views (the chunk's views stacked; negative where invalid).
@group(0) @binding(2) var<storage, read> w_p: array<f32>;
// sigma_vis of the views (the chunk's views stacked).
@group(0) @binding(3) var<storage, read> visibility: array<f32>;
// The sparse maps' color and mask (4 per pixel).
@group(0) @binding(4) var<storage, read> sparse_color_mask: array<f32>;
// Out: w_D and lambda_PC w_H; before the last chunk of views, the partial sums of w_P and of
// sigma_vis.
@group(0) @binding(5) var<storage, read_write> w_d: array<f32>;
@group(0) @binding(6) var<storage, read_write> attach: array<f32>;

fn color_at(i: u32) -> vec3<f32> {
    return vec3<f32>(color_rgb[i * 3u], color_rgb[i * 3u + 1u], color_rgb[i * 3u + 2u]);
}

// ||grad I||^2 by central differences (one-sided at the border), summed over RGB.
fn gradient_sq(x: u32, y: u32) -> f32 {
    let w = params.width;
    let h = params.height;
    let xl = select(x - 1u, 0u, x == 0u);
    let xr = min(x + 1u, w - 1u);
    let yu = select(y - 1u, 0u, y == 0u);
    let yd = min(y + 1u, h - 1u);
    var sx = 0.0;
    if (xr > xl) {
        sx = 1.0 / f32(xr - xl);
    }
    var sy = 0.0;
    if (yd > yu) {
        sy = 1.0 / f32(yd - yu);
    }
    let l = color_at(y * w + xl);
    let r = color_at(y * w + xr);
    let u = color_at(yu * w + x);
    let d = color_at(yd * w + x);
    var sum = 0.0;
    for (var k = 0u; k < 3u; k = k + 1u) {
        let gx = (r[k] - l[k]) * sx;
        let gy = (d[k] - u[k]) * sy;
        sum = sum + (gx * gx + gy * gy);
    }
    return sum;
}

@compute @workgroup_size(8, 8)
fn depth_weights(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var sum_wp = 0.0;
    var sum_vis = 0.0;
    if (!is_first_chunk(params.chunk)) {
        sum_wp = w_d[i];
        sum_vis = attach[i];
    }
    for (var s = 0u; s < params.views; s = s + 1u) {
        sum_wp = sum_wp + max(w_p[s * n + i], 0.0);
        sum_vis = sum_vis + visibility[s * n + i];
    }
    if (!is_last_chunk(params.chunk)) {
        w_d[i] = sum_wp;
        attach[i] = sum_vis;
        return;
    }
    let g = gradient_sq(id.x, id.y) * params.gradient_unit * params.gradient_unit + params.eps_gradient;
    let v = sum_vis + params.eps_visibility;
    w_d[i] = clamp(sum_wp / (g * v), params.w_d_min, params.w_d_max);
    var w_h = 0.0;
    if (sparse_color_mask[i * 4u + 3u] > 0.0) {
        let sparse = vec3<f32>(sparse_color_mask[i * 4u], sparse_color_mask[i * 4u + 1u], sparse_color_mask[i * 4u + 2u]);
        w_h = agreement(sparse, color_at(i), params.sigma);
    }
    attach[i] = params.lambda_pc * w_h;
}
