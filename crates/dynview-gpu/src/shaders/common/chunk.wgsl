// Kernels that sum over the views run once per chunk of views (views.rs: where the views'
// images do not fit one binding, they are split into buffers of whole views). `chunk` in their
// uniform block holds these flags: the first chunk starts its sums from zero, the others add
// to the partial sums the previous chunk stored, and the last finishes them. With one chunk
// both flags are set.

const FIRST_CHUNK: u32 = 1u;
const LAST_CHUNK: u32 = 2u;

fn is_first_chunk(flags: u32) -> bool {
    return (flags & FIRST_CHUNK) != 0u;
}

fn is_last_chunk(flags: u32) -> bool {
    return (flags & LAST_CHUNK) != 0u;
}
