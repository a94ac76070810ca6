// The temporal terms as the depth and color systems take them (dynview-core's
// render::frame::depth_terms and color_terms): (lambda_T w_T, previous depth) and
// (lambda_T w_T, previous RGB), lambda_T scaled by the sparse coverage when asked.

struct Params {
    width: u32,
    height: u32,
    // 1 when lambda_T is scaled by the sparse coverage.
    coverage_scaling: u32,
    lambda_t: f32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> w_t: array<f32>;
// The previous frame splatted into this view: depth (m) and color (RGB).
@group(0) @binding(2) var<storage, read> previous_depth_m: array<f32>;
@group(0) @binding(3) var<storage, read> previous_rgb: array<f32>;
// The consistency filter's counters (u32 bits): [1] = covered pixels after the filter.
@group(0) @binding(4) var<storage, read> sparse_counters: array<u32>;
// Out: (lambda_T w_T, previous depth) and (lambda_T w_T, previous RGB) per pixel.
@group(0) @binding(5) var<storage, read_write> depth_terms: array<f32>;
@group(0) @binding(6) var<storage, read_write> color_terms: array<f32>;

@compute @workgroup_size(8, 8)
fn temporal_terms(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var lambda_t = params.lambda_t;
    if (params.coverage_scaling != 0u) {
        lambda_t = params.lambda_t * f32(sparse_counters[1]) / f32(max(n, 1u));
    }
    let t = lambda_t * w_t[i];
    depth_terms[i * 2u] = t;
    depth_terms[i * 2u + 1u] = previous_depth_m[i];
    color_terms[i * 4u] = t;
    color_terms[i * 4u + 1u] = previous_rgb[i * 3u];
    color_terms[i * 4u + 2u] = previous_rgb[i * 3u + 1u];
    color_terms[i * 4u + 3u] = previous_rgb[i * 3u + 2u];
}
