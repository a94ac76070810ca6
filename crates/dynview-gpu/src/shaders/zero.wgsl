// Fills a buffer with zeros: `words` 32-bit words as rows of `row_words`, one invocation per
// word (a 2D grid, so that any buffer size stays within the dispatch limits). It replaces a
// clear command, which would end the compute pass the frame records into.

struct Params {
    words: u32,
    row_words: u32,
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> data: array<u32>;

@compute @workgroup_size(8, 8)
fn zero(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.y * params.row_words + id.x;
    if (id.x >= params.row_words || i >= params.words) {
        return;
    }
    data[i] = 0u;
}
