// The grid system both red-black kernels sweep (red_black.wgsl, red_black_tiled.wgsl), as
// dynview-core's GridSystem: diag_i u_i - sum_j a_ij u_j = rhs_i with 4-neighbour couplings.

// Coupling of pixel i with i + 1 (0 in the last column).
@group(0) @binding(1) var<storage, read> right: array<f32>;
// Coupling of pixel i with i + width (0 in the last row).
@group(0) @binding(2) var<storage, read> down: array<f32>;
// 1 / diag_i.
@group(0) @binding(3) var<storage, read> inv_diag: array<f32>;
// The right-hand side, `channels` floats per pixel.
@group(0) @binding(4) var<storage, read> rhs: array<f32>;
