// The sparse maps' color and mask as one RGB + mask image, as the depth weights take them
// (assemble/depth_weights.wgsl).

struct Params {
    width: u32,
    height: u32,
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> color_rgb: array<f32>;
@group(0) @binding(2) var<storage, read> mask: array<f32>;
// Out: RGB and mask per pixel.
@group(0) @binding(3) var<storage, read_write> color_mask: array<f32>;

@compute @workgroup_size(8, 8)
fn pack_color_mask(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let i = id.y * params.width + id.x;
    color_mask[i * 4u] = color_rgb[i * 3u];
    color_mask[i * 4u + 1u] = color_rgb[i * 3u + 1u];
    color_mask[i * 4u + 2u] = color_rgb[i * 3u + 2u];
    color_mask[i * 4u + 3u] = mask[i];
}
