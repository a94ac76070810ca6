// f32 bit patterns shared by the shaders: infinity and the finite test.

// The bits of +infinity. Positive floats order as their bits, so a z-buffer of depth bits
// starts here and takes atomic minima.
const INFINITY_BITS: u32 = 0x7f800000u;

// The largest finite f32: `d <= MAX_FINITE` is false for +infinity and NaN.
const MAX_FINITE: f32 = 0x1.fffffep+127f;

// +infinity at run time: WGSL forbids an infinite constant (Tint rejects a constant-folded
// bitcast), so the bits come from a variable.
var<private> infinity_bits: u32 = 0x7f800000u;

// Neither infinite nor NaN (the exponent bits are not all set).
fn is_finite(d: f32) -> bool {
    return (bitcast<u32>(d) & INFINITY_BITS) != INFINITY_BITS;
}
