// The weights of METHOD.md and the assembly of the depth and color systems from them,
// following dynview-core's render::weights and render::solve term by term. The outputs feed
// red_black.wgsl.
//
// Views are packed: view s's pixel i is at s * n + i (n = width * height). Entry points, in
// order: projection_weights, depth_weights, depth_system, color_system.

struct Params {
    width: u32,
    height: u32,
    views: u32,
    _pad0: u32,
    sigma: f32,
    lambda_pc: f32,
    lambda_p: f32,
    lambda_g: f32,
    gradient_unit: f32,
    eps_gradient: f32,
    eps_visibility: f32,
    w_d_min: f32,
    w_d_max: f32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
// projection_weights: color, warp colors, visibility, validity -> w_p.
// depth_weights:      color, w_p, visibility, sparse color+mask -> w_d, attach.
// depth_system:       w_d, attach, sparse depth, temporal (t, previous depth) -> system.
// color_system:       warp colors, w_p, temporal (t, previous rgb) -> system.
@group(0) @binding(1) var<storage, read> in1: array<f32>;
@group(0) @binding(2) var<storage, read> in2: array<f32>;
@group(0) @binding(3) var<storage, read> in3: array<f32>;
@group(0) @binding(4) var<storage, read> in4: array<f32>;
@group(0) @binding(5) var<storage, read_write> out1: array<f32>;
@group(0) @binding(6) var<storage, read_write> out2: array<f32>;
@group(0) @binding(7) var<storage, read_write> out3: array<f32>;
@group(0) @binding(8) var<storage, read_write> out4: array<f32>;

fn agreement(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let d = a - b;
    let d2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
    return exp(-d2 / (2.0 * params.sigma * params.sigma));
}

fn rgb(buffer_index: u32, i: u32) -> vec3<f32> {
    switch buffer_index {
        case 1u: { return vec3<f32>(in1[i * 3u], in1[i * 3u + 1u], in1[i * 3u + 2u]); }
        case 2u: { return vec3<f32>(in2[i * 3u], in2[i * 3u + 1u], in2[i * 3u + 2u]); }
        default: { return vec3<f32>(0.0); }
    }
}

// w_P^s = sigma_vis^s exp(-||P^s - I||^2 / 2 sigma^2); stored as -1 where the warp of view s
// is invalid (outside its image), which later passes read as "invalid, weight 0".
// in1 = color, in2 = warp colors, in3 = visibility, in4 = validity (1 or 0). out1 = w_p.
@compute @workgroup_size(8, 8)
fn projection_weights(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    let color = rgb(1u, i);
    for (var s = 0u; s < params.views; s = s + 1u) {
        let j = s * n + i;
        var w = 0.0;
        let vis = in3[j];
        if (vis > 0.0) {
            w = vis * agreement(rgb(2u, j), color);
        }
        if (in4[j] <= 0.0) {
            w = -1.0;
        }
        out1[j] = w;
    }
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
    let l = rgb(1u, y * w + xl);
    let r = rgb(1u, y * w + xr);
    let u = rgb(1u, yu * w + x);
    let d = rgb(1u, yd * w + x);
    var sum = 0.0;
    for (var k = 0u; k < 3u; k = k + 1u) {
        let gx = (r[k] - l[k]) * sx;
        let gy = (d[k] - u[k]) * sy;
        sum = sum + (gx * gx + gy * gy);
    }
    return sum;
}

// w_D = clamp(sum w_P / ((|grad (u I)|^2 + eps_g)(sum sigma_vis + eps_v)), w_d_min, w_d_max) and
// attach = lambda_PC w_H (w_H the agreement of the sparse color where a point landed).
// in1 = color, in2 = w_p, in3 = visibility, in4 = sparse color + mask (4 per pixel).
// out1 = w_d, out2 = attach.
@compute @workgroup_size(8, 8)
fn depth_weights(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var sum_wp = 0.0;
    var sum_vis = 0.0;
    for (var s = 0u; s < params.views; s = s + 1u) {
        sum_wp = sum_wp + max(in2[s * n + i], 0.0);
        sum_vis = sum_vis + in3[s * n + i];
    }
    let g = gradient_sq(id.x, id.y) * params.gradient_unit * params.gradient_unit + params.eps_gradient;
    let v = sum_vis + params.eps_visibility;
    out1[i] = clamp(sum_wp / (g * v), params.w_d_min, params.w_d_max);
    var w_h = 0.0;
    if (in4[i * 4u + 3u] > 0.0) {
        w_h = agreement(vec3<f32>(in4[i * 4u], in4[i * 4u + 1u], in4[i * 4u + 2u]), rgb(1u, i));
    }
    out2[i] = params.lambda_pc * w_h;
}

fn finite_or_zero(v: f32) -> f32 {
    if (abs(v) <= 0x1.fffffep+127f) {
        return v;
    }
    return 0.0;
}

// The depth system: couplings 0.5 (w_D,x + w_D,y), diagonal, right-hand side.
// in1 = w_d, in2 = attach, in3 = sparse depth, in4 = temporal (t, previous depth).
// out1 = right, out2 = down, out3 = inv_diag, out4 = rhs.
@compute @workgroup_size(8, 8)
fn depth_system(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    let w = params.width;
    let h = params.height;
    if (x >= w || y >= h) {
        return;
    }
    let i = y * w + x;
    var right = 0.0;
    if (x + 1u < w) {
        right = 0.5 * (in1[i] + in1[i + 1u]);
    }
    var down = 0.0;
    if (y + 1u < h) {
        down = 0.5 * (in1[i] + in1[i + w]);
    }
    let t = in4[i * 2u];
    var diag = in2[i] + t;
    diag = diag + (right + down);
    if (x > 0u) {
        diag = diag + 0.5 * (in1[i - 1u] + in1[i]);
    }
    if (y > 0u) {
        diag = diag + 0.5 * (in1[i - w] + in1[i]);
    }
    out1[i] = right;
    out2[i] = down;
    out3[i] = select(0.0, 1.0 / diag, diag > 0.0);
    out4[i] = in2[i] * finite_or_zero(in3[i]) + t * finite_or_zero(in4[i * 2u + 1u]);
}

// w^s_xy: mean of the endpoints' w_P^s, 0 when either warp is invalid (w_p < 0).
fn edge_weight(s: u32, i: u32, j: u32) -> f32 {
    let n = params.width * params.height;
    let a = in2[s * n + i];
    let b = in2[s * n + j];
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
            g = g + (rgb(1u, s * n + i) - rgb(1u, s * n + j)) * (params.lambda_g * we);
        }
    }
    return g;
}

// The color system, shared by the channels: couplings 1 + lambda_G sum_s w^s_xy; diagonal with
// lambda_P w_P^s and the temporal term; right-hand side with the gradient targets.
// in1 = warp colors, in2 = w_p, in4 = temporal (t, previous rgb).
// out1 = right, out2 = down, out3 = inv_diag, out4 = rhs (3 per pixel).
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
    var right = 0.0;
    var g_right = vec3<f32>(0.0);
    if (x + 1u < w) {
        right = edge_coupling(i, i + 1u);
        g_right = edge_target(i, i + 1u);
    }
    var down = 0.0;
    var g_down = vec3<f32>(0.0);
    if (y + 1u < h) {
        down = edge_coupling(i, i + w);
        g_down = edge_target(i, i + w);
    }
    var diag = right + down;
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
        let wp = in2[s * n + i];
        if (wp > 0.0) {
            diag = diag + params.lambda_p * wp;
            b = b + rgb(1u, s * n + i) * (params.lambda_p * wp);
        }
    }
    let t = in4[i * 4u];
    if (t > 0.0) {
        diag = diag + t;
        b = b + vec3<f32>(in4[i * 4u + 1u], in4[i * 4u + 2u], in4[i * 4u + 3u]) * t;
    }
    out1[i] = right;
    out2[i] = down;
    out3[i] = 1.0 / diag;
    out4[i * 3u] = b.x;
    out4[i * 3u + 1u] = b.y;
    out4[i * 3u + 2u] = b.z;
}
