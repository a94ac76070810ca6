// The plane's pull (dynview-core's render::plane), folded into the depth system's temporal
// terms so that assemble/depth_system.wgsl needs no further binding.
//
// Its weight per pixel is render::plane::plane_weights: lambda_plane (1 - min(1, coverage /
// support_coverage)), where coverage is the share of pixels with a sparse point in the
// (2 radius + 1)^2 window around the pixel, clipped to the image. Two passes: window sums along
// rows, then along columns. The sums count pixels (integers), so they equal the CPU's exactly.
//
// Two terms t (D - Dprev)^2 + p (D - Dplane)^2 are one term (t + p)(D - (t Dprev + p Dplane) /
// (t + p))^2 plus a constant, the same system.

struct SupportParams {
    width: u32,
    height: u32,
    radius: u32,
    _pad0: u32,
    lambda_plane: f32,
    support_coverage: f32,
    // The plane, 1/z = a x + b y + c in this level's pixels, its inverse depth clamped to
    // [plane_inverse_min, plane_inverse_max] (render::plane::PixelPlane).
    plane_a: f32,
    plane_b: f32,
    plane_c: f32,
    plane_inverse_min: f32,
    plane_inverse_max: f32,
    _pad1: u32,
};

@group(0) @binding(0) var<uniform> params: SupportParams;
// In: the sparse mask (support_rows) or the row sums (plane_prior).
@group(0) @binding(1) var<storage, read> sums_in: array<f32>;
// Out: the row sums (support_rows), the temporal terms with the plane's folded in, (weight,
// target depth) per pixel (plane_prior), or how far each pixel is from the points' support,
// 1 - min(1, coverage / support_coverage) (unsupported, the weight with lambda = 1).
@group(0) @binding(2) var<storage, read_write> sums_out: array<f32>;
// The temporal terms, (lambda_T w_T, previous depth) per pixel (plane_prior only).
@group(0) @binding(3) var<storage, read> temporal: array<f32>;

@compute @workgroup_size(8, 8)
fn support_rows(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = params.width;
    if (id.x >= w || id.y >= params.height) {
        return;
    }
    let lo = max(id.x, params.radius) - params.radius;
    let hi = min(id.x + params.radius, w - 1u);
    var covered = 0.0;
    for (var x = lo; x <= hi; x = x + 1u) {
        covered = covered + select(0.0, 1.0, sums_in[id.y * w + x] > 0.0);
    }
    sums_out[id.y * w + id.x] = covered;
}

// The share of the pixels with a point in the window around pixel (x, y), from the row sums.
fn coverage(x: u32, y: u32) -> f32 {
    let w = params.width;
    let lo = max(y, params.radius) - params.radius;
    let hi = min(y + params.radius, params.height - 1u);
    var covered = 0.0;
    for (var r = lo; r <= hi; r = r + 1u) {
        covered = covered + sums_in[r * w + x];
    }
    let xl = max(x, params.radius) - params.radius;
    let xh = min(x + params.radius, w - 1u);
    let pixels = f32((hi - lo + 1u) * (xh - xl + 1u));
    return covered / pixels;
}

@compute @workgroup_size(8, 8)
fn unsupported(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    sums_out[id.y * params.width + id.x] = 1.0 - min(coverage(id.x, id.y) / params.support_coverage, 1.0);
}

@compute @workgroup_size(8, 8)
fn plane_prior(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = params.width;
    let h = params.height;
    if (id.x >= w || id.y >= h) {
        return;
    }
    let i = id.y * w + id.x;
    let p = params.lambda_plane * (1.0 - min(coverage(id.x, id.y) / params.support_coverage, 1.0));
    let t = temporal[i * 2u];
    let previous = temporal[i * 2u + 1u];
    if (p <= 0.0) {
        sums_out[i * 2u] = t;
        sums_out[i * 2u + 1u] = previous;
        return;
    }
    let inverse = params.plane_a * f32(id.x) + params.plane_b * f32(id.y) + params.plane_c;
    let plane_depth = 1.0 / clamp(inverse, params.plane_inverse_min, params.plane_inverse_max);
    // t is 0 where the temporal terms are off: its previous depth may then be anything.
    var weighted = p * plane_depth;
    if (t > 0.0) {
        weighted = weighted + t * previous;
    }
    sums_out[i * 2u] = t + p;
    sums_out[i * 2u + 1u] = weighted / (t + p);
}
