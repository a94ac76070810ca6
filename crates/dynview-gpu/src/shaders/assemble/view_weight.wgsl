// The view weight the viewer shows (dynview-core's render job keeps the same): sum_s w_P^s,
// invalid warps (stored as -1) counting 0. Run once per chunk of views (common/chunk.wgsl):
// later chunks add to the sum.

// w_P of the views (the chunk's views stacked; negative where invalid).
@group(0) @binding(1) var<storage, read> w_p: array<f32>;
// Out: sum_s w_P^s.
@group(0) @binding(2) var<storage, read_write> sum_wp: array<f32>;

@compute @workgroup_size(8, 8)
fn view_weight(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    var sum = 0.0;
    if (!is_first_chunk(params.chunk)) {
        sum = sum_wp[i];
    }
    for (var s = 0u; s < params.views; s = s + 1u) {
        sum = sum + max(w_p[s * n + i], 0.0);
    }
    sum_wp[i] = sum;
}
