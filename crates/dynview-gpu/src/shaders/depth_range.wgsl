// The range of the false-color depth display, on the GPU: the 2nd and 98th percentiles of the
// finite depths (as dynview-core's display::colorize_depth), found from a histogram between the
// minimum and the maximum. Three passes: bounds_of, histogram_of, percentiles.

const BINS: u32 = 1024u;

struct Params {
    width: u32,
    height: u32,
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> depth: array<f32>;
// Order-preserving keys of the smallest and largest finite depth (start: 0xffffffff, 0).
@group(0) @binding(2) var<storage, read_write> bounds: array<atomic<u32>, 2>;
@group(0) @binding(3) var<storage, read_write> histogram: array<atomic<u32>, BINS>;
// Out: the low and high end of the range, in metres.
@group(0) @binding(4) var<storage, read_write> range: array<f32, 2>;

// A u32 that orders as the float does.
fn key(d: f32) -> u32 {
    let b = bitcast<u32>(d);
    if ((b & 0x80000000u) != 0u) {
        return ~b;
    }
    return b | 0x80000000u;
}

fn unkey(k: u32) -> f32 {
    if ((k & 0x80000000u) != 0u) {
        return bitcast<f32>(k & 0x7fffffffu);
    }
    return bitcast<f32>(~k);
}

fn depth_at(id: vec3<u32>) -> f32 {
    return depth[id.y * params.width + id.x];
}

@compute @workgroup_size(8, 8)
fn bounds_of(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let d = depth_at(id);
    if (is_finite(d)) {
        atomicMin(&bounds[0], key(d));
        atomicMax(&bounds[1], key(d));
    }
}

@compute @workgroup_size(8, 8)
fn histogram_of(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let d = depth_at(id);
    if (!is_finite(d)) {
        return;
    }
    let lo = unkey(atomicLoad(&bounds[0]));
    let hi = unkey(atomicLoad(&bounds[1]));
    let u = (d - lo) / max(hi - lo, 1e-30);
    let bin = min(u32(clamp(u, 0.0, 1.0) * f32(BINS)), BINS - 1u);
    atomicAdd(&histogram[bin], 1u);
}

// The value of rank `k` among the sorted finite depths, interpolated inside its bin.
fn value_of_rank(k: u32, lo: f32, hi: f32) -> f32 {
    var before = 0u;
    for (var b = 0u; b < BINS; b = b + 1u) {
        let count = atomicLoad(&histogram[b]);
        if (k < before + count) {
            let within = (f32(k - before) + 0.5) / f32(count);
            return lo + (f32(b) + within) * (hi - lo) / f32(BINS);
        }
        before = before + count;
    }
    return hi;
}

@compute @workgroup_size(1)
fn percentiles(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x != 0u || id.y != 0u) {
        return;
    }
    let lo_key = atomicLoad(&bounds[0]);
    let hi_key = atomicLoad(&bounds[1]);
    if (lo_key > hi_key) {
        // No finite depth at all.
        range[0] = 0.0;
        range[1] = 1.0;
        return;
    }
    let lo = unkey(lo_key);
    let hi = unkey(hi_key);
    var total = 0u;
    for (var b = 0u; b < BINS; b = b + 1u) {
        total = total + atomicLoad(&histogram[b]);
    }
    range[0] = value_of_rank(total / 50u, lo, hi);
    range[1] = value_of_rank((total / 50u) * 49u + ((total % 50u) * 49u) / 50u, lo, hi);
}
