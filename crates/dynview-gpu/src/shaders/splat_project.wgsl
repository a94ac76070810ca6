// Projection of splat sources into a target camera: the sparse cloud (world points) or a
// rendered frame (pixels with depth, through the pixel transfer), following dynview-core's
// render::sparse term by term. Each source element gets the target pixel it lands on
// (rounded; OUTSIDE when off the image or behind the camera), its depth and its color; the
// z-buffer resolve is in splat_resolve.wgsl.

struct Params {
    // Number of source elements.
    count: u32,
    // Target image size.
    width: u32,
    height: u32,
    // Source frame width (project_pixels).
    source_width: u32,
    // project_points: rows of camera_from_world (rotation | translation), then fx, fy, cx, cy.
    // project_pixels: rows of the transfer matrix M (xyz) and e.
    row0: vec4<f32>,
    row1: vec4<f32>,
    row2: vec4<f32>,
    extra: vec4<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
// project_points: positions (3 floats per point). project_pixels: source depth.
@group(0) @binding(1) var<storage, read> source_geometry: array<f32>;
// project_points: colors as packed RGBA8 (one u32 per point). project_pixels: source RGB floats.
@group(0) @binding(2) var<storage, read> source_color: array<u32>;
@group(0) @binding(3) var<storage, read_write> element_target: array<u32>;
@group(0) @binding(4) var<storage, read_write> element_depth: array<f32>;
@group(0) @binding(5) var<storage, read_write> element_color: array<f32>;

// Rounds half away from zero, as Rust's f32::round.
fn round_half_away(v: f32) -> f32 {
    return sign(v) * floor(abs(v) + 0.5);
}

fn emit(e: u32, u: f32, v: f32, z: f32, color: vec3<f32>) {
    let x = round_half_away(u);
    let y = round_half_away(v);
    element_target[e] = OUTSIDE;
    if (!(x >= 0.0 && y >= 0.0 && x < f32(params.width) && y < f32(params.height))) {
        return;
    }
    element_target[e] = u32(y) * params.width + u32(x);
    element_depth[e] = z;
    element_color[e * 3u] = color.x;
    element_color[e * 3u + 1u] = color.y;
    element_color[e * 3u + 2u] = color.z;
}

@compute @workgroup_size(64)
fn project_points(@builtin(global_invocation_id) id: vec3<u32>) {
    let e = id.x;
    if (e >= params.count) {
        return;
    }
    element_target[e] = OUTSIDE;
    let p = vec3<f32>(source_geometry[e * 3u], source_geometry[e * 3u + 1u], source_geometry[e * 3u + 2u]);
    let xc = params.row0.x * p.x + params.row0.y * p.y + params.row0.z * p.z + params.row0.w;
    let yc = params.row1.x * p.x + params.row1.y * p.y + params.row1.z * p.z + params.row1.w;
    let zc = params.row2.x * p.x + params.row2.y * p.y + params.row2.z * p.z + params.row2.w;
    if (zc <= 1e-6) {
        return;
    }
    let u = params.extra.x * xc / zc + params.extra.z;
    let v = params.extra.y * yc / zc + params.extra.w;
    let c = unpack4x8unorm(source_color[e]);
    // unit_from_u8: code * (1 / 255).
    let color = vec3<f32>(round(c.x * 255.0), round(c.y * 255.0), round(c.z * 255.0)) * (1.0 / 255.0);
    emit(e, u, v, zc, color);
}

@compute @workgroup_size(64)
fn project_pixels(@builtin(global_invocation_id) id: vec3<u32>) {
    let e = id.x;
    if (e >= params.count) {
        return;
    }
    element_target[e] = OUTSIDE;
    let d = source_geometry[e];
    if (!(d > 0.0 && d <= MAX_FINITE)) {
        return;
    }
    let x = f32(e % params.source_width);
    let y = f32(e / params.source_width);
    let hz = d * (params.row2.x * x + params.row2.y * y + params.row2.z) + params.extra.z;
    if (!(hz > 1e-6)) {
        return;
    }
    let hx = d * (params.row0.x * x + params.row0.y * y + params.row0.z) + params.extra.x;
    let hy = d * (params.row1.x * x + params.row1.y * y + params.row1.z) + params.extra.y;
    let inv = 1.0 / hz;
    let color = vec3<f32>(bitcast<f32>(source_color[e * 3u]), bitcast<f32>(source_color[e * 3u + 1u]), bitcast<f32>(source_color[e * 3u + 2u]));
    emit(e, hx * inv, hy * inv, hz, color);
}
