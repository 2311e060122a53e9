// An instance's vertex placed in f64 (with the adapter's SHADER_F64): the scene-local point
// computed as osw_scene::instance::Placement::point does, in the same order, rounded to f32,
// then made camera-relative like every scene-local vertex. A use thus draws exactly what its
// placed copy would, and what the CPU's cluster and triangle tests saw.

struct Rows {
    x: vec4<f64>,
    y: vec4<f64>,
    z: vec4<f64>,
}

fn row(r: vec4<f64>, p: vec3<f64>) -> f64 {
    return ((r.x * p.x + r.y * p.y) + r.z * p.z) + r.w;
}

fn place(r: Rows, position: vec3<f32>) -> vec3<f32> {
    let p = vec3<f64>(position);
    return vec3<f32>(vec3<f64>(row(r.x, p), row(r.y, p), row(r.z, p))) + view.offset.xyz;
}

// The rows' linear part, for normals (draw.wgsl's `turned`).
fn linear_rows(r: Rows) -> array<vec3<f32>, 3> {
    return array<vec3<f32>, 3>(vec3<f32>(r.x.xyz), vec3<f32>(r.y.xyz), vec3<f32>(r.z.xyz));
}
