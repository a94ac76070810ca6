// The depth system (dynview-core's render::solve::DepthTerms::system): couplings
// 0.5 (w_D,x + w_D,y), the diagonal and the right-hand side.

@group(0) @binding(1) var<storage, read> w_d: array<f32>;
// lambda_PC w_H.
@group(0) @binding(2) var<storage, read> attach: array<f32>;
// The sparse depth (m; infinite where no point landed).
@group(0) @binding(3) var<storage, read> sparse_depth_m: array<f32>;
// The temporal terms: (lambda_T w_T, previous depth) per pixel.
@group(0) @binding(4) var<storage, read> temporal: array<f32>;
// Out: the system.
@group(0) @binding(5) var<storage, read_write> right: array<f32>;
@group(0) @binding(6) var<storage, read_write> down: array<f32>;
@group(0) @binding(7) var<storage, read_write> inv_diag: array<f32>;
@group(0) @binding(8) var<storage, read_write> rhs: array<f32>;

fn finite_or_zero(v: f32) -> f32 {
    if (abs(v) <= MAX_FINITE) {
        return v;
    }
    return 0.0;
}

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
    var r = 0.0;
    if (x + 1u < w) {
        r = 0.5 * (w_d[i] + w_d[i + 1u]);
    }
    var d = 0.0;
    if (y + 1u < h) {
        d = 0.5 * (w_d[i] + w_d[i + w]);
    }
    let t = temporal[i * 2u];
    var diag = attach[i] + t;
    diag = diag + (r + d);
    if (x > 0u) {
        diag = diag + 0.5 * (w_d[i - 1u] + w_d[i]);
    }
    if (y > 0u) {
        diag = diag + 0.5 * (w_d[i - w] + w_d[i]);
    }
    right[i] = r;
    down[i] = d;
    inv_diag[i] = select(0.0, 1.0 / diag, diag > 0.0);
    rhs[i] = attach[i] * finite_or_zero(sparse_depth_m[i]) + t * finite_or_zero(temporal[i * 2u + 1u]);
}
