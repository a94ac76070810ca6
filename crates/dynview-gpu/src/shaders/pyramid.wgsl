// Image pyramid resampling, following dynview-core's render::pyramid term by term: 2x2 box
// downsampling (edge pixels of odd sizes average what exists) and bilinear upsampling with
// pixel centres aligned (common/bilinear.wgsl). Images are flat arrays of `channels` floats per pixel.

struct Dims {
    src_width: u32,
    src_height: u32,
    dst_width: u32,
    dst_height: u32,
    channels: u32,
    // src / dst size ratios, computed on the host exactly as the CPU path does.
    scale_x: f32,
    scale_y: f32,
    _pad: u32,
};

@group(0) @binding(0) var<uniform> dims: Dims;
@group(0) @binding(1) var<storage, read> src: array<f32>;
@group(0) @binding(2) var<storage, read_write> dst: array<f32>;

fn at(x: u32, y: u32, c: u32) -> f32 {
    return src[(y * dims.src_width + x) * dims.channels + c];
}

@compute @workgroup_size(8, 8)
fn downsample(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= dims.dst_width || id.y >= dims.dst_height) {
        return;
    }
    let x0 = 2u * id.x;
    let x1 = min(2u * id.x + 1u, dims.src_width - 1u);
    let y0 = 2u * id.y;
    let y1 = min(2u * id.y + 1u, dims.src_height - 1u);
    for (var c = 0u; c < dims.channels; c = c + 1u) {
        let sum = ((at(x0, y0, c) + at(x1, y0, c)) + at(x0, y1, c)) + at(x1, y1, c);
        dst[(id.y * dims.dst_width + id.x) * dims.channels + c] = sum * 0.25;
    }
}

@compute @workgroup_size(8, 8)
fn upsample(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= dims.dst_width || id.y >= dims.dst_height) {
        return;
    }
    let t = bilinear_taps(id.x, id.y, vec2<f32>(dims.scale_x, dims.scale_y), vec2<u32>(dims.src_width, dims.src_height));
    for (var c = 0u; c < dims.channels; c = c + 1u) {
        dst[(id.y * dims.dst_width + id.x) * dims.channels + c] =
            bilinear_mix(t, at(t.x0, t.y0, c), at(t.x1, t.y0, c), at(t.x0, t.y1, c), at(t.x1, t.y1, c));
    }
}
