// One colour of a red-black over-relaxed Gauss-Seidel sweep of a screened Poisson system on a
// width x height grid with 4-neighbour couplings (dynview-core's GridSystem):
//   diag_i u_i - sum_j a_ij u_j = rhs_i
// `u` and `rhs` hold `channels` floats per pixel (1 for depth, 3 for color). Pixels with
// (x + y) % 2 == parity are updated in place; their neighbours all have the other parity, so
// the update order within one colour does not matter. The arithmetic follows the CPU solver
// term by term.

struct Params {
    width: u32,
    height: u32,
    parity: u32,
    channels: u32,
    omega: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
// Bindings 1 to 4: the system (common/grid_system.wgsl).
@group(0) @binding(5) var<storage, read_write> u: array<f32>;

@compute @workgroup_size(8, 8)
fn sweep(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    let w = params.width;
    if (x >= w || y >= params.height || ((x + y) & 1u) != params.parity) {
        return;
    }
    let i = y * w + x;
    let n = params.channels;
    for (var c = 0u; c < n; c = c + 1u) {
        var acc = rhs[i * n + c];
        if (x > 0u) {
            acc = acc + u[(i - 1u) * n + c] * right[i - 1u];
        }
        if (x + 1u < w) {
            acc = acc + u[(i + 1u) * n + c] * right[i];
        }
        if (y > 0u) {
            acc = acc + u[(i - w) * n + c] * down[i - w];
        }
        if (y + 1u < params.height) {
            acc = acc + u[(i + w) * n + c] * down[i];
        }
        let gs = acc * inv_diag[i];
        let old = u[i * n + c];
        u[i * n + c] = old + (gs + old * -1.0) * params.omega;
    }
}
