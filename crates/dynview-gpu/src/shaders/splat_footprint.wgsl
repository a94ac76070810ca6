// Every sparse sample attached over its footprint, as dynview-core's
// sparse::SplatMaps::with_footprint: a pixel without a sample takes the nearest one (smallest
// depth; the first in row-major order among equals) within `radius` pixels. Also counts the
// covered pixels after, for the temporal terms' coverage scaling (counters[1], as the
// consistency filter's).

struct FootprintParams {
    width: u32,
    height: u32,
    radius: u32,
    _pad0: u32,
};

@group(0) @binding(0) var<uniform> params: FootprintParams;
@group(0) @binding(1) var<storage, read> depth_in: array<f32>;
@group(0) @binding(2) var<storage, read> color_in: array<f32>;
@group(0) @binding(3) var<storage, read> mask_in: array<f32>;
// Out: the maps with footprints.
@group(0) @binding(4) var<storage, read_write> depth_out: array<f32>;
@group(0) @binding(5) var<storage, read_write> color_out: array<f32>;
@group(0) @binding(6) var<storage, read_write> mask_out: array<f32>;
// [1]: covered pixels after ([0] unused).
@group(0) @binding(7) var<storage, read_write> counters: array<atomic<u32>>;

@compute @workgroup_size(8, 8)
fn footprint(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = params.width;
    let h = params.height;
    if (id.x >= w || id.y >= h) {
        return;
    }
    let i = id.y * w + id.x;
    var source = i;
    if (mask_in[i] <= 0.0) {
        var found = false;
        var best = 0u;
        let ylo = max(id.y, params.radius) - params.radius;
        let yhi = min(id.y + params.radius, h - 1u);
        let xlo = max(id.x, params.radius) - params.radius;
        let xhi = min(id.x + params.radius, w - 1u);
        for (var y = ylo; y <= yhi; y = y + 1u) {
            for (var x = xlo; x <= xhi; x = x + 1u) {
                let j = y * w + x;
                if (mask_in[j] > 0.0 && (!found || depth_in[j] < depth_in[best])) {
                    best = j;
                    found = true;
                }
            }
        }
        if (found) {
            source = best;
        }
    }
    depth_out[i] = depth_in[source];
    color_out[i * 3u] = color_in[source * 3u];
    color_out[i * 3u + 1u] = color_in[source * 3u + 1u];
    color_out[i * 3u + 2u] = color_in[source * 3u + 2u];
    let covered = mask_in[source] > 0.0;
    mask_out[i] = select(0.0, 1.0, covered);
    if (covered) {
        atomicAdd(&counters[1], 1u);
    }
}
