// The z-buffer of a splat: per target pixel, the nearest element wins; among equally near
// elements the first (lowest index), as the CPU's sequential splat. Entry points, in order:
// clear (over target pixels), nearest_depth, first_index, write (over elements).

struct Params {
    count: u32,
    pixels: u32,
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> element_target: array<u32>;
@group(0) @binding(2) var<storage, read> element_depth: array<f32>;
@group(0) @binding(3) var<storage, read> element_color: array<f32>;
@group(0) @binding(4) var<storage, read_write> zbuf: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> winner: array<atomic<u32>>;
// The splat maps: depth (infinite where nothing landed), RGB color, mask.
@group(0) @binding(6) var<storage, read_write> out_depth: array<f32>;
@group(0) @binding(7) var<storage, read_write> out_color: array<f32>;
@group(0) @binding(8) var<storage, read_write> out_mask: array<f32>;

@compute @workgroup_size(64)
fn clear(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(id, groups);
    if (i >= params.pixels) {
        return;
    }
    atomicStore(&zbuf[i], INFINITY_BITS);
    atomicStore(&winner[i], OUTSIDE);
    out_depth[i] = bitcast<f32>(infinity_bits);
    out_color[i * 3u] = 0.0;
    out_color[i * 3u + 1u] = 0.0;
    out_color[i * 3u + 2u] = 0.0;
    out_mask[i] = 0.0;
}

@compute @workgroup_size(64)
fn nearest_depth(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(id, groups);
    if (e >= params.count || element_target[e] == OUTSIDE) {
        return;
    }
    atomicMin(&zbuf[element_target[e]], bitcast<u32>(element_depth[e]));
}

@compute @workgroup_size(64)
fn first_index(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(id, groups);
    if (e >= params.count || element_target[e] == OUTSIDE) {
        return;
    }
    let t = element_target[e];
    if (bitcast<u32>(element_depth[e]) == atomicLoad(&zbuf[t])) {
        atomicMin(&winner[t], e);
    }
}

@compute @workgroup_size(64)
fn write(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(id, groups);
    if (e >= params.count || element_target[e] == OUTSIDE) {
        return;
    }
    let t = element_target[e];
    if (atomicLoad(&winner[t]) == e) {
        out_depth[t] = element_depth[e];
        out_color[t * 3u] = element_color[e * 3u];
        out_color[t * 3u + 1u] = element_color[e * 3u + 1u];
        out_color[t * 3u + 2u] = element_color[e * 3u + 2u];
        out_mask[t] = 1.0;
    }
}
