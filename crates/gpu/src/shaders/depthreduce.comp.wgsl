// The farthest-depth pyramid for the pyramid box test (same reduction as the CPU pyramid of
// osw-cull's hzb.rs): level 0 is the depth buffer, each texel of level k the minimum of the
// 2x2 texels below it (reversed Z: minimum = farthest), edges clamped. Level 0 is copied from
// the depth texture (a plain copy: reading a million depth texels in a shader costs several
// times more on a software rasteriser); then one dispatch per level, `step.level` saying which
// level it writes.

struct Step {
    level: u32,
}

@group(0) @binding(0) var<storage, read> levels: array<Level>;
@group(0) @binding(1) var<storage, read_write> pyramid: array<f32>;
@group(0) @binding(2) var<uniform> step: Step;

@compute @workgroup_size(8, 8)
fn reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let dst = levels[step.level];
    if id.x >= dst.width || id.y >= dst.height {
        return;
    }
    let src = levels[step.level - 1u];
    let x0 = min(2u * id.x, src.width - 1u);
    let x1 = min(2u * id.x + 1u, src.width - 1u);
    let y0 = src.offset + min(2u * id.y, src.height - 1u) * src.pitch;
    let y1 = src.offset + min(2u * id.y + 1u, src.height - 1u) * src.pitch;
    let d = min(min(pyramid[y0 + x0], pyramid[y0 + x1]), min(pyramid[y1 + x0], pyramid[y1 + x1]));
    pyramid[dst.offset + id.y * dst.pitch + id.x] = d;
}
