// Fills a buffer with zeros, one invocation per 32-bit word (a linear kernel: long buffers
// fold into rows of workgroups, `common/linear.wgsl`). It replaces a clear command, which
// would end the compute pass the frame records into.

struct Params {
    words: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> data: array<u32>;

@compute @workgroup_size(64)
fn zero(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(id, groups);
    if (i < params.words) {
        data[i] = 0u;
    }
}
