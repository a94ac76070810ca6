// Projection of the sparse cloud (world points) into a target camera, following dynview-core's
// render::sparse::project_cloud term by term (without the consistency filter). The output
// bindings and `emit` are in common/splat_emit.wgsl.

struct Params {
    // Number of points projected.
    count: u32,
    // Target image size.
    width: u32,
    height: u32,
    // Index of the first point projected (a range of the cloud: the static mask splats its
    // own and its static points apart).
    first: u32,
    // Rows of the target's camera_from_world: rotation row i in xyz, translation i in w.
    camera_from_world_row0: vec4<f32>,
    camera_from_world_row1: vec4<f32>,
    camera_from_world_row2: vec4<f32>,
    // The target's fx, fy, cx, cy in pixels.
    focal_principal_px: vec4<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
// World positions, 3 floats per point.
@group(0) @binding(1) var<storage, read> positions_world: array<f32>;
// Colors as packed RGBA8, one u32 per point.
@group(0) @binding(2) var<storage, read> colors_rgba8: array<u32>;

@compute @workgroup_size(64)
fn project_points(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(id, groups);
    if (e >= params.count) {
        return;
    }
    element_target[e] = OUTSIDE;
    let q = params.first + e;
    let p = vec4<f32>(positions_world[q * 3u], positions_world[q * 3u + 1u], positions_world[q * 3u + 2u], 1.0);
    let r0 = params.camera_from_world_row0;
    let r1 = params.camera_from_world_row1;
    let r2 = params.camera_from_world_row2;
    let xc = r0.x * p.x + r0.y * p.y + r0.z * p.z + r0.w;
    let yc = r1.x * p.x + r1.y * p.y + r1.z * p.z + r1.w;
    let zc = r2.x * p.x + r2.y * p.y + r2.z * p.z + r2.w;
    if (zc <= 1e-6) {
        return;
    }
    let k = params.focal_principal_px;
    let u = k.x * xc / zc + k.z;
    let v = k.y * yc / zc + k.w;
    let c = unpack4x8unorm(colors_rgba8[q]);
    // unit_from_u8: code * (1 / 255).
    let color = vec3<f32>(round(c.x * 255.0), round(c.y * 255.0), round(c.z * 255.0)) * (1.0 / 255.0);
    emit(e, u, v, zc, color, params.width, params.height);
}
