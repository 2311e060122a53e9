// An instance's vertex placed in f32 (adapters without 64-bit floats in shaders): the rows'
// translation is already camera-relative, taken in f64 on the CPU, so that precision does not
// fall with the distance from the origin; within a rounding of place64.wgsl's exact placement.

struct Rows {
    x: vec4<f32>,
    y: vec4<f32>,
    z: vec4<f32>,
    // The f64 layout's size (uses.rs writes one layout).
    unused: array<vec4<f32>, 3>,
}

fn place(r: Rows, position: vec3<f32>) -> vec3<f32> {
    let p = vec4<f32>(position, 1.0);
    return vec3<f32>(dot(r.x, p), dot(r.y, p), dot(r.z, p));
}

// The rows' linear part, for normals (draw.wgsl's `turned`).
fn linear_rows(r: Rows) -> array<vec3<f32>, 3> {
    return array<vec3<f32>, 3>(r.x.xyz, r.y.xyz, r.z.xyz);
}
