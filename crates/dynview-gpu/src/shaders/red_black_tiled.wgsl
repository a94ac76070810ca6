// Red-black over-relaxed Gauss-Seidel half-sweeps (one colour each) of a screened Poisson
// system, as red_black.wgsl (same system, same arithmetic term by term), but several
// half-sweeps in one dispatch (temporal blocking). Each workgroup copies its tile of
// TILE x TILE pixels with a halo of HALO pixels on every side from `u_in` into workgroup memory,
// runs up to HALO half-sweeps there, and writes its tile to `u_out`. A pixel at the edge of
// that region lacks its neighbours outside it and is not updated: that error moves one pixel
// per half-sweep, so after HALO half-sweeps it has not reached the tile, which then holds what
// as many half-sweeps over the whole grid give. `u_in` and `u_out` are different buffers: a
// workgroup reads its halo where other workgroups write their tiles.

const TILE: u32 = 16u;
const HALO: u32 = 4u;
// TILE + 2 HALO.
const SIDE: u32 = 24u;
const MAX_CHANNELS: u32 = 3u;

struct Params {
    width: u32,
    height: u32,
    // The colour of the first half-sweep (they alternate).
    parity: u32,
    channels: u32,
    omega: f32,
    // Half-sweeps in this dispatch (1 to HALO).
    half_sweeps: u32,
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
// Bindings 1 to 4: the system (common/grid_system.wgsl).
// The unknowns before and after this dispatch's half-sweeps.
@group(0) @binding(5) var<storage, read> u_in: array<f32>;
@group(0) @binding(6) var<storage, read_write> u_out: array<f32>;

// The region's unknowns, SIDE x SIDE pixels of MAX_CHANNELS floats.
var<workgroup> region: array<f32, 1728>;

@compute @workgroup_size(16, 16)
fn sweeps(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let w = params.width;
    let h = params.height;
    let n = params.channels;
    // The region's first pixel (may lie left of or above the grid).
    let ox = i32(group.x * TILE) - i32(HALO);
    let oy = i32(group.y * TILE) - i32(HALO);
    for (var k = local; k < SIDE * SIDE; k = k + TILE * TILE) {
        let gx = ox + i32(k % SIDE);
        let gy = oy + i32(k / SIDE);
        if (gx >= 0 && gy >= 0 && gx < i32(w) && gy < i32(h)) {
            let i = u32(gy) * w + u32(gx);
            for (var c = 0u; c < n; c = c + 1u) {
                region[k * MAX_CHANNELS + c] = u_in[i * n + c];
            }
        }
    }
    workgroupBarrier();
    for (var s = 0u; s < params.half_sweeps; s = s + 1u) {
        let parity = (params.parity + s) & 1u;
        for (var k = local; k < SIDE * SIDE; k = k + TILE * TILE) {
            let lx = k % SIDE;
            let ly = k / SIDE;
            let gx = ox + i32(lx);
            let gy = oy + i32(ly);
            if (gx < 0 || gy < 0 || gx >= i32(w) || gy >= i32(h)) {
                continue;
            }
            let x = u32(gx);
            let y = u32(gy);
            // Every neighbour the grid has must lie in the region.
            let inside = (x == 0u || lx > 0u) && (x + 1u == w || lx + 1u < SIDE) && (y == 0u || ly > 0u) && (y + 1u == h || ly + 1u < SIDE);
            if (((x + y) & 1u) != parity || !inside) {
                continue;
            }
            let i = y * w + x;
            for (var c = 0u; c < n; c = c + 1u) {
                var acc = rhs[i * n + c];
                if (x > 0u) {
                    acc = acc + region[(k - 1u) * MAX_CHANNELS + c] * right[i - 1u];
                }
                if (x + 1u < w) {
                    acc = acc + region[(k + 1u) * MAX_CHANNELS + c] * right[i];
                }
                if (y > 0u) {
                    acc = acc + region[(k - SIDE) * MAX_CHANNELS + c] * down[i - w];
                }
                if (y + 1u < h) {
                    acc = acc + region[(k + SIDE) * MAX_CHANNELS + c] * down[i];
                }
                let gs = acc * inv_diag[i];
                let old = region[k * MAX_CHANNELS + c];
                region[k * MAX_CHANNELS + c] = old + (gs + old * -1.0) * params.omega;
            }
        }
        workgroupBarrier();
    }
    // Each invocation writes its own pixel of the tile.
    let x = group.x * TILE + local % TILE;
    let y = group.y * TILE + local / TILE;
    if (x < w && y < h) {
        let r = (local / TILE + HALO) * SIDE + local % TILE + HALO;
        let i = y * w + x;
        for (var c = 0u; c < n; c = c + 1u) {
            u_out[i * n + c] = region[r * MAX_CHANNELS + c];
        }
    }
}
