// The rank preference of the color energy (dynview-core's render::weights::
// apply_rank_preference): each view's w_P^s scaled by 1 + u preference_s, where u is how far
// the pixel is from the points' support (plane_support.wgsl's `unsupported`) and
// preference_s = r_s^gamma - 1 from the view's relative rank (0 for the best view). Views are
// stacked per chunk of views (common/chunk.wgsl): view s of the chunk has its pixel i at
// s * n + i (n = width * height).

struct RankParams {
    width: u32,
    height: u32,
    views: u32,
    _pad0: u32,
    // preference_s of each view of the chunk (up to 8).
    preferences: array<vec4<f32>, 2>,
};

@group(0) @binding(0) var<uniform> params: RankParams;
// u per pixel, in [0, 1].
@group(0) @binding(1) var<storage, read> unsupported: array<f32>;
// w_P of the views (the chunk's views stacked; negative where the warp is invalid, left so),
// scaled in place.
@group(0) @binding(2) var<storage, read_write> w_p: array<f32>;

@compute @workgroup_size(8, 8)
fn rank_preference(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    let u = unsupported[i];
    for (var s = 0u; s < params.views; s = s + 1u) {
        let preference = params.preferences[s / 4u][s % 4u];
        let j = s * n + i;
        if (preference != 0.0 && w_p[j] > 0.0) {
            w_p[j] = w_p[j] * (1.0 + u * preference);
        }
    }
}
