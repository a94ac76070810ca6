// The Gaussian color agreement shared by all weights (dynview-core's render::weights::agreement):
// exp(-||a - b||^2 / (2 sigma^2)).
fn agreement(a: vec3<f32>, b: vec3<f32>, sigma: f32) -> f32 {
    let d = a - b;
    let d2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
    return exp(-d2 / (2.0 * sigma * sigma));
}
