// The color system (dynview-core's render::solve::ColorTerms::system), shared by the channels:
// couplings 1 + lambda_G sum_s w^s_xy; the diagonal with lambda_P w_P^s and the temporal term;
// the right-hand side with the gradient targets.

// Warped colors of the views (RGB, packed).
@group(0) @binding(1) var<storage, read> warp_rgb: array<f32>;
// w_P of the views (packed; negative where invalid).
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

fn edge_coupling(i: u32, j: u32) -> f32 {
    var sum = 0.0;
    for (var s = 0u; s < params.views; s = s + 1u) {
        sum = sum + edge_weight(s, i, j);
    }
    return 1.0 + params.lambda_g * sum;
}

// g_xy = lambda_G sum_s w^s_xy (P^s_x - P^s_y), in view order.
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
    var r = 0.0;
    var g_right = vec3<f32>(0.0);
    if (x + 1u < w) {
        r = edge_coupling(i, i + 1u);
        g_right = edge_target(i, i + 1u);
    }
    var d = 0.0;
    var g_down = vec3<f32>(0.0);
    if (y + 1u < h) {
        d = edge_coupling(i, i + w);
        g_down = edge_target(i, i + w);
    }
    var diag = r + d;
    var b = (g_right - vec3<f32>(0.0)) + g_down;
    if (x > 0u) {
        diag = diag + edge_coupling(i - 1u, i);
        b = b - edge_target(i - 1u, i);
    }
    if (y > 0u) {
        diag = diag + edge_coupling(i - w, i);
        b = b - edge_target(i - w, i);
    }
    for (var s = 0u; s < params.views; s = s + 1u) {
        let wp = w_p[s * n + i];
        if (wp > 0.0) {
            diag = diag + params.lambda_p * wp;
            b = b + warp_at(s * n + i) * (params.lambda_p * wp);
        }
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
