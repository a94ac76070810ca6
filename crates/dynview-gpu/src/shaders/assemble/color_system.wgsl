// The color system (dynview-core's render::solve::ColorTerms::system), shared by the channels:
// couplings 1 + lambda_G sum_s w^s_xy; the diagonal with lambda_P w_P^s and the temporal term;
// the right-hand side with the gradient targets.

// Warped colors of the views (RGB, the chunk's views stacked).
@group(0) @binding(1) var<storage, read> warp_rgb: array<f32>;
// w_P of the views (the chunk's views stacked; negative where invalid).
@group(0) @binding(2) var<storage, read> w_p: array<f32>;
// The temporal terms: (lambda_T w_T, previous RGB) per pixel.
@group(0) @binding(3) var<storage, read> temporal: array<f32>;
// Out: the system (the right-hand side RGB).
@group(0) @binding(4) var<storage, read_write> right: array<f32>;
@group(0) @binding(5) var<storage, read_write> down: array<f32>;
@group(0) @binding(6) var<storage, read_write> inv_diag: array<f32>;
@group(0) @binding(7) var<storage, read_write> rhs: array<f32>;

fn warp_at(j: u32) -> vec3<f32> {
    return vec3<f32>(warp_rgb[j * 3u], warp_rgb[j * 3u + 1u], warp_rgb[j * 3u + 2u]);
}

// w^s_xy: mean of the endpoints' w_P^s, 0 when either warp is invalid (w_p < 0).
fn edge_weight(s: u32, i: u32, j: u32) -> f32 {
    let n = params.width * params.height;
    let a = w_p[s * n + i];
    let b = w_p[s * n + j];
    if (a < 0.0 || b < 0.0) {
        return 0.0;
    }
    return 0.5 * (a + b);
}

// sum_s w^s_xy over the chunk's views.
fn edge_weight_sum(i: u32, j: u32) -> f32 {
    var sum = 0.0;
    for (var s = 0u; s < params.views; s = s + 1u) {
        sum = sum + edge_weight(s, i, j);
    }
    return sum;
}

// g_xy = lambda_G sum_s w^s_xy (P^s_x - P^s_y) over the chunk's views, in view order.
fn edge_target(i: u32, j: u32) -> vec3<f32> {
    let n = params.width * params.height;
    var g = vec3<f32>(0.0);
    for (var s = 0u; s < params.views; s = s + 1u) {
        let we = edge_weight(s, i, j);
        if (we > 0.0) {
            g = g + (warp_at(s * n + i) - warp_at(s * n + j)) * (params.lambda_g * we);
        }
    }
    return g;
}

// Couplings 1 + lambda_G sum_s w^s_xy of the right and down edges, the diagonal (the four
// edges' couplings, lambda_P sum_s w_P^s and the temporal weight) and the right-hand side.
// Before the last chunk of views, `right` and `down` hold the partial sums sum_s w^s_xy,
// `inv_diag` the diagonal's partial sum of the view terms of the left and up edges and of
// lambda_P w_P^s, and `rhs` the right-hand side's partial sum.
@compute @workgroup_size(8, 8)
fn color_system(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    let w = params.width;
    let h = params.height;
    if (x >= w || y >= h) {
        return;
    }
    let n = w * h;
    let i = y * w + x;
    var sum_right = 0.0;
    var sum_down = 0.0;
    var diag_views = 0.0;
    var b = vec3<f32>(0.0);
    if (!is_first_chunk(params.chunk)) {
        sum_right = right[i];
        sum_down = down[i];
        diag_views = inv_diag[i];
        b = vec3<f32>(rhs[i * 3u], rhs[i * 3u + 1u], rhs[i * 3u + 2u]);
    }
    if (x + 1u < w) {
        sum_right = sum_right + edge_weight_sum(i, i + 1u);
        b = b + edge_target(i, i + 1u);
    }
    if (y + 1u < h) {
        sum_down = sum_down + edge_weight_sum(i, i + w);
        b = b + edge_target(i, i + w);
    }
    if (x > 0u) {
        diag_views = diag_views + params.lambda_g * edge_weight_sum(i - 1u, i);
        b = b - edge_target(i - 1u, i);
    }
    if (y > 0u) {
        diag_views = diag_views + params.lambda_g * edge_weight_sum(i - w, i);
        b = b - edge_target(i - w, i);
    }
    for (var s = 0u; s < params.views; s = s + 1u) {
        let wp = w_p[s * n + i];
        if (wp > 0.0) {
            diag_views = diag_views + params.lambda_p * wp;
            b = b + warp_at(s * n + i) * (params.lambda_p * wp);
        }
    }
    if (!is_last_chunk(params.chunk)) {
        right[i] = sum_right;
        down[i] = sum_down;
        inv_diag[i] = diag_views;
        rhs[i * 3u] = b.x;
        rhs[i * 3u + 1u] = b.y;
        rhs[i * 3u + 2u] = b.z;
        return;
    }
    var r = 0.0;
    if (x + 1u < w) {
        r = 1.0 + params.lambda_g * sum_right;
    }
    var d = 0.0;
    if (y + 1u < h) {
        d = 1.0 + params.lambda_g * sum_down;
    }
    var diag = r + d + diag_views;
    if (x > 0u) {
        diag = diag + 1.0;
    }
    if (y > 0u) {
        diag = diag + 1.0;
    }
    let t = temporal[i * 4u];
    if (t > 0.0) {
        diag = diag + t;
        b = b + vec3<f32>(temporal[i * 4u + 1u], temporal[i * 4u + 2u], temporal[i * 4u + 3u]) * t;
    }
    right[i] = r;
    down[i] = d;
    inv_diag[i] = 1.0 / diag;
    rhs[i * 3u] = b.x;
    rhs[i * 3u + 1u] = b.y;
    rhs[i * 3u + 2u] = b.z;
}
