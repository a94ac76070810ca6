// Drawing a rendered frame into a canvas (or any render target) straight from the renderer's
// storage buffers: a full-screen triangle whose fragments sample the frame as dynview-core's
// display::picture shows it (color bilinear; depth false-colored, near yellow, far blue, over
// the range from depth_range.wgsl; view weights as gray levels).

struct Params {
    src_width: u32,
    src_height: u32,
    dst_width: u32,
    dst_height: u32,
    // 0 color, 1 depth, 2 weights.
    mode: u32,
    views: u32,
    // 1 when the target format is sRGB (the hardware encodes: write linear values).
    srgb_target: u32,
    _pad: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> color: array<f32>;
@group(0) @binding(2) var<storage, read> depth: array<f32>;
// sum_s w_P^s over the `views` views (src size; empty when `views` is 0).
@group(0) @binding(3) var<storage, read> weights: array<f32>;
@group(0) @binding(4) var<storage, read> range: array<f32>;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs(@builtin(vertex_index) index: u32) -> VertexOut {
    let x = f32((index << 1u) & 2u);
    let y = f32(index & 2u);
    var out: VertexOut;
    out.position = vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
    return out;
}

fn rgb_at(x: u32, y: u32) -> vec3<f32> {
    let i = (y * params.src_width + x) * 3u;
    return vec3<f32>(color[i], color[i + 1u], color[i + 2u]);
}

fn to_linear(c: vec3<f32>) -> vec3<f32> {
    let low = c / 12.92;
    let high = pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4));
    return select(high, low, c <= vec3<f32>(0.04045));
}

@fragment
fn fs(in: VertexOut) -> @location(0) vec4<f32> {
    let sw = f32(params.src_width);
    let sh = f32(params.src_height);
    // Source pixel coordinates of this fragment's centre (pixel centres at integers).
    let sx = clamp(in.position.x * sw / f32(params.dst_width) - 0.5, 0.0, sw - 1.0);
    let sy = clamp(in.position.y * sh / f32(params.dst_height) - 0.5, 0.0, sh - 1.0);
    let nearest_x = u32(round(sx));
    let nearest_y = u32(round(sy));
    let nearest = nearest_y * params.src_width + nearest_x;
    var out = vec3<f32>(0.0);
    if (params.mode == 0u) {
        let x0 = u32(floor(sx));
        let y0 = u32(floor(sy));
        let x1 = min(x0 + 1u, params.src_width - 1u);
        let y1 = min(y0 + 1u, params.src_height - 1u);
        let fx = sx - f32(x0);
        let fy = sy - f32(y0);
        let top = mix(rgb_at(x0, y0), rgb_at(x1, y0), fx);
        let bottom = mix(rgb_at(x0, y1), rgb_at(x1, y1), fx);
        out = clamp(mix(top, bottom, fy), vec3<f32>(0.0), vec3<f32>(1.0));
    } else if (params.mode == 1u) {
        let d = depth[nearest];
        if (is_finite(d)) {
            let u = clamp((d - range[0]) / max(range[1] - range[0], 1e-6), 0.0, 1.0);
            out = vec3<f32>(1.0 - u, 0.8 - 0.5 * u, 0.2 + 0.8 * u);
        }
    } else {
        if (params.views > 0u) {
            out = vec3<f32>(clamp(weights[nearest] * (1.0 / f32(params.views)), 0.0, 1.0));
        }
    }
    if (params.srgb_target == 1u) {
        out = to_linear(out);
    }
    return vec4<f32>(out, 1.0);
}
