// The sparse consistency filter of dynview-core's SplatMaps::drop_inconsistent, term by term:
// in a window of radius r (half the mean spacing of the samples, 1 to 8 pixels) remove
// (1) isolated front samples: none within `ratio` of its depth, at least two clearly behind;
// (2) occluded samples: a remaining sample nearer by more than the factor 1 + ratio, or, within
// `surround` pixels (0: no such test), such nearer samples in each of its four closed quadrants
// (dynview-core's render::surround). An isolated front sample is kept when a sample within
// `ratio` of its depth lies within `surround` pixels (a sparse surface in front of a dense one).
// Entry points, in order: count (covered before), isolated, occluded, apply (also counts the
// covered pixels after, for the temporal terms' coverage scaling). Infinity: common/float_bits.wgsl.

struct Params {
    width: u32,
    height: u32,
    ratio: f32,
    surround: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> depth: array<f32>;
@group(0) @binding(2) var<storage, read_write> mask: array<f32>;
// [0, n): removed as isolated; [n, 2n): removed as occluded.
@group(0) @binding(3) var<storage, read_write> flags: array<u32>;
// [0]: covered before the filter; [1]: covered after.
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;

fn in_bounds(id: vec3<u32>) -> bool {
    return id.x < params.width && id.y < params.height;
}

@compute @workgroup_size(8, 8)
fn count(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_bounds(id)) {
        return;
    }
    let i = id.y * params.width + id.x;
    let n = params.width * params.height;
    flags[i] = 0u;
    flags[n + i] = 0u;
    if (mask[i] > 0.0) {
        atomicAdd(&counters[0], 1u);
    }
}

fn radius() -> u32 {
    let covered = atomicLoad(&counters[0]);
    let spacing = sqrt(f32(params.width * params.height) / f32(covered));
    return u32(clamp(ceil(0.5 * spacing), 1.0, 8.0));
}

@compute @workgroup_size(8, 8)
fn isolated(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_bounds(id)) {
        return;
    }
    let w = params.width;
    let h = params.height;
    let i = id.y * w + id.x;
    if (!(mask[i] > 0.0)) {
        return;
    }
    let r = radius();
    let d = depth[i];
    var support = 0u;
    var behind = 0u;
    for (var yy = select(id.y - r, 0u, id.y < r); yy <= min(id.y + r, h - 1u); yy = yy + 1u) {
        for (var xx = select(id.x - r, 0u, id.x < r); xx <= min(id.x + r, w - 1u); xx = xx + 1u) {
            let j = yy * w + xx;
            if (j != i && mask[j] > 0.0) {
                let dj = depth[j];
                if (abs(dj - d) <= params.ratio * d) {
                    support = support + 1u;
                } else if (dj > d * (1.0 + params.ratio)) {
                    behind = behind + 1u;
                }
            }
        }
    }
    if (support == 0u && behind >= 2u && !(params.surround > r && wide_support(id.xy, d))) {
        flags[i] = 1u;
    }
}

// Whether a sample within `ratio` of depth `d` lies within `surround` pixels of `p` (not at `p`).
fn wide_support(p: vec2<u32>, d: f32) -> bool {
    let w = params.width;
    let h = params.height;
    let s = params.surround;
    let i = p.y * w + p.x;
    for (var yy = select(p.y - s, 0u, p.y < s); yy <= min(p.y + s, h - 1u); yy = yy + 1u) {
        for (var xx = select(p.x - s, 0u, p.x < s); xx <= min(p.x + s, w - 1u); xx = xx + 1u) {
            let j = yy * w + xx;
            if (j != i && mask[j] > 0.0 && abs(depth[j] - d) <= params.ratio * d) {
                return true;
            }
        }
    }
    return false;
}

// Whether samples not removed as isolated and nearer than `d` by the factor 1 + ratio lie in
// each of the four closed quadrants of `surround` pixels around `p`.
fn surrounded(p: vec2<u32>, d: f32) -> bool {
    let w = params.width;
    let h = params.height;
    let s = params.surround;
    var quadrants = 0u;
    for (var yy = select(p.y - s, 0u, p.y < s); yy <= min(p.y + s, h - 1u); yy = yy + 1u) {
        for (var xx = select(p.x - s, 0u, p.x < s); xx <= min(p.x + s, w - 1u); xx = xx + 1u) {
            let j = yy * w + xx;
            if (mask[j] > 0.0 && flags[j] == 0u && d > depth[j] * (1.0 + params.ratio)) {
                let up = yy <= p.y;
                let down = yy >= p.y;
                let left = xx <= p.x;
                let right = xx >= p.x;
                quadrants = quadrants | select(0u, 1u, up && left) | select(0u, 2u, up && right)
                    | select(0u, 4u, down && left) | select(0u, 8u, down && right);
            }
        }
    }
    return quadrants == 15u;
}

@compute @workgroup_size(8, 8)
fn occluded(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_bounds(id)) {
        return;
    }
    let w = params.width;
    let h = params.height;
    let n = w * h;
    let i = id.y * w + id.x;
    if (!(mask[i] > 0.0) || flags[i] != 0u) {
        return;
    }
    let r = radius();
    let d = depth[i];
    if (params.surround > 0u && surrounded(id.xy, d)) {
        flags[n + i] = 1u;
        return;
    }
    for (var yy = select(id.y - r, 0u, id.y < r); yy <= min(id.y + r, h - 1u); yy = yy + 1u) {
        for (var xx = select(id.x - r, 0u, id.x < r); xx <= min(id.x + r, w - 1u); xx = xx + 1u) {
            let j = yy * w + xx;
            if (j != i && mask[j] > 0.0 && flags[j] == 0u && d > depth[j] * (1.0 + params.ratio)) {
                flags[n + i] = 1u;
                return;
            }
        }
    }
}

@compute @workgroup_size(8, 8)
fn apply(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_bounds(id)) {
        return;
    }
    let n = params.width * params.height;
    let i = id.y * params.width + id.x;
    if (flags[i] != 0u || flags[n + i] != 0u) {
        mask[i] = 0.0;
        depth[i] = bitcast<f32>(infinity_bits);
    }
    if (mask[i] > 0.0) {
        atomicAdd(&counters[1], 1u);
    }
}
