// The farthest-depth pyramid for the pyramid box test (same reduction as the CPU pyramid of
// osw-cull's hzb.rs): level 0 is the depth buffer, each texel of level k the minimum of the
// 2x2 texels below it (reversed Z: minimum = farthest), edges clamped. Level 0 is copied from
// the depth texture (a plain copy: reading a million depth texels in a shader costs several
// times more on a software rasteriser); then each dispatch writes two levels, `step.level`
// and, when `step.two` is set, the one above it: on lavapipe a dispatch costs about as much
// as a level of a quarter million texels.

struct Step {
    level: u32,
    two: u32,
}

@group(0) @binding(0) var<storage, read> levels: array<Level>;
@group(0) @binding(1) var<storage, read_write> pyramid: array<f32>;
@group(0) @binding(2) var<uniform> step: Step;

// Texel (x, y) of level l, from the 2x2 texels of level l - 1 below it.
fn reduced(l: u32, x: u32, y: u32) -> f32 {
    let src = levels[l - 1u];
    let x0 = min(2u * x, src.width - 1u);
    let x1 = min(2u * x + 1u, src.width - 1u);
    let y0 = src.offset + min(2u * y, src.height - 1u) * src.pitch;
    let y1 = src.offset + min(2u * y + 1u, src.height - 1u) * src.pitch;
    return min(min(pyramid[y0 + x0], pyramid[y0 + x1]), min(pyramid[y1 + x0], pyramid[y1 + x1]));
}

// One invocation per texel of the top level written.
@compute @workgroup_size(8, 8)
fn reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let mid = levels[step.level];
    if step.two == 0u {
        if id.x < mid.width && id.y < mid.height {
            pyramid[mid.offset + id.y * mid.pitch + id.x] = reduced(step.level, id.x, id.y);
        }
        return;
    }
    let top = levels[step.level + 1u];
    if id.x >= top.width || id.y >= top.height {
        return;
    }
    // The 2x2 texels of `mid` below this one (clamped at the edges, as `reduced` clamps),
    // each written once: by the invocation above it.
    var d = 3.4e38;
    for (var dy = 0u; dy < 2u; dy++) {
        for (var dx = 0u; dx < 2u; dx++) {
            let x = 2u * id.x + dx;
            let y = 2u * id.y + dy;
            let v = reduced(step.level, min(x, mid.width - 1u), min(y, mid.height - 1u));
            if x < mid.width && y < mid.height {
                pyramid[mid.offset + y * mid.pitch + x] = v;
            }
            d = min(d, v);
        }
    }
    pyramid[top.offset + id.y * top.pitch + id.x] = d;
}
