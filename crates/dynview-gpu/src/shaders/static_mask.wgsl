// The plates' static mask of a novel view, following dynview-core's render::plates::static_mask
// step by step, from the step's own points and its static points splatted apart (each with its
// footprint, splat_footprint.wgsl). Entry points, in order:
// farthest (where the reach exceeds the footprint): the static points' depth where it has one,
// elsewhere the farthest of it over the square window of `radius` (infinite where none);
// nearer: 1 where an own point lies more than NEARER_MARGIN nearer than the static surface;
// grown: 1 - the maximum of `nearer` over the square window of `radius` (the static pixels);
// feathered: the mean of `grown` over the square window of `radius` cut at the image's edges.
// `is_finite` is common/float_bits.wgsl's.

struct MaskParams {
    width: u32,
    height: u32,
    // The window's radius (grown, feathered); unused by nearer.
    radius: u32,
    // plates::NEARER_MARGIN.
    nearer_margin: f32,
};

@group(0) @binding(0) var<uniform> params: MaskParams;
// nearer: the own points' depth; farthest: the static points'; grown and feathered: the step
// before's mask.
@group(0) @binding(1) var<storage, read> first_in: array<f32>;
// nearer: the static points' depth; unused by the others (bound to `first_in`'s buffer).
@group(0) @binding(2) var<storage, read> second_in: array<f32>;
@group(0) @binding(3) var<storage, read_write> mask_out: array<f32>;

@compute @workgroup_size(8, 8)
fn nearer(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let i = id.y * params.width + id.x;
    let own = first_in[i];
    let stat = second_in[i];
    // An infinite static depth (no static point there) counts as farther than any own point.
    let in_front = is_finite(own) && (!is_finite(stat) || own < stat * (1.0 - params.nearer_margin));
    mask_out[i] = select(0.0, 1.0, in_front);
}

@compute @workgroup_size(8, 8)
fn farthest(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = params.width;
    let h = params.height;
    if (id.x >= w || id.y >= h) {
        return;
    }
    let depth = first_in[id.y * w + id.x];
    if (is_finite(depth)) {
        mask_out[id.y * w + id.x] = depth;
        return;
    }
    let r = params.radius;
    var largest = 0.0;
    for (var y = max(id.y, r) - r; y <= min(id.y + r, h - 1u); y = y + 1u) {
        for (var x = max(id.x, r) - r; x <= min(id.x + r, w - 1u); x = x + 1u) {
            let d = first_in[y * w + x];
            if (is_finite(d)) {
                largest = max(largest, d);
            }
        }
    }
    // No static depth around: infinite, as the splat leaves it.
    mask_out[id.y * w + id.x] = select(bitcast<f32>(infinity_bits), largest, largest > 0.0);
}

@compute @workgroup_size(8, 8)
fn grown(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = params.width;
    let h = params.height;
    if (id.x >= w || id.y >= h) {
        return;
    }
    let r = params.radius;
    var largest = 0.0;
    for (var y = max(id.y, r) - r; y <= min(id.y + r, h - 1u); y = y + 1u) {
        for (var x = max(id.x, r) - r; x <= min(id.x + r, w - 1u); x = x + 1u) {
            largest = max(largest, first_in[y * w + x]);
        }
    }
    mask_out[id.y * w + id.x] = 1.0 - largest;
}

@compute @workgroup_size(8, 8)
fn feathered(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = params.width;
    let h = params.height;
    if (id.x >= w || id.y >= h) {
        return;
    }
    let r = params.radius;
    let ylo = max(id.y, r) - r;
    let yhi = min(id.y + r, h - 1u);
    let xlo = max(id.x, r) - r;
    let xhi = min(id.x + r, w - 1u);
    var sum = 0.0;
    for (var y = ylo; y <= yhi; y = y + 1u) {
        for (var x = xlo; x <= xhi; x = x + 1u) {
            sum = sum + first_in[y * w + x];
        }
    }
    mask_out[id.y * w + id.x] = sum / f32((yhi - ylo + 1u) * (xhi - xlo + 1u));
}
