// The output of a splat projection (splat_points.wgsl, splat_pixels.wgsl): for each source
// element, the target pixel it lands on (rounded; OUTSIDE when off the image or behind the
// camera), its depth and its color. The z-buffer resolve is in splat_resolve.wgsl.

@group(0) @binding(3) var<storage, read_write> element_target: array<u32>;
@group(0) @binding(4) var<storage, read_write> element_depth: array<f32>;
@group(0) @binding(5) var<storage, read_write> element_color: array<f32>;

// Rounds half away from zero, as Rust's f32::round.
fn round_half_away(v: f32) -> f32 {
    return sign(v) * floor(abs(v) + 0.5);
}

// Element `e` lands at pixel (u, v) of a `width` x `height` target with depth `z`.
fn emit(e: u32, u: f32, v: f32, z: f32, color: vec3<f32>, width: u32, height: u32) {
    let x = round_half_away(u);
    let y = round_half_away(v);
    element_target[e] = OUTSIDE;
    if (!(x >= 0.0 && y >= 0.0 && x < f32(width) && y < f32(height))) {
        return;
    }
    element_target[e] = u32(y) * width + u32(x);
    element_depth[e] = z;
    element_color[e * 3u] = color.x;
    element_color[e * 3u + 1u] = color.y;
    element_color[e * 3u + 2u] = color.z;
}
