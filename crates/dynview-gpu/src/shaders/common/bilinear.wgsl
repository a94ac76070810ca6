// Bilinear sampling with pixel centres aligned (dynview-core's render::pyramid::upsample), shared
// by the pyramid's upsampling and push-pull's push: the four source pixels around a destination
// pixel and the weights between them.

struct BilinearTaps {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    tx: f32,
    ty: f32,
};

// The taps of destination pixel (x, y) in a source of `src_size`; `scale` is source / destination
// size, computed on the host as the CPU path does.
fn bilinear_taps(x: u32, y: u32, scale: vec2<f32>, src_size: vec2<u32>) -> BilinearTaps {
    let fy = clamp((f32(y) + 0.5) * scale.y - 0.5, 0.0, f32(src_size.y - 1u));
    let fx = clamp((f32(x) + 0.5) * scale.x - 0.5, 0.0, f32(src_size.x - 1u));
    let y0 = u32(floor(fy));
    let x0 = u32(floor(fx));
    let y1 = min(y0 + 1u, src_size.y - 1u);
    let x1 = min(x0 + 1u, src_size.x - 1u);
    return BilinearTaps(x0, y0, x1, y1, fx - f32(x0), fy - f32(y0));
}

// The bilinear mix of the values at (x0, y0), (x1, y0), (x0, y1), (x1, y1): rows first, as the
// CPU path.
fn bilinear_mix(t: BilinearTaps, v00: f32, v10: f32, v01: f32, v11: f32) -> f32 {
    let top = v00 * (1.0 - t.tx) + v10 * t.tx;
    let bottom = v01 * (1.0 - t.tx) + v11 * t.tx;
    return top * (1.0 - t.ty) + bottom * t.ty;
}
