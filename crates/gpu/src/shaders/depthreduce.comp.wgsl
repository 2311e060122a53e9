// The farthest-depth pyramid for the pyramid box test (same reduction as the CPU pyramid of
// osw-cull's hzb.rs): level 0 is the depth buffer, each texel of level k the minimum of the
// 2x2 texels below it (reversed Z: minimum = farthest), edges clamped. One dispatch per
// level; `step.level` says which level this dispatch writes (0 = copy from the texture).

struct Step {
    level: u32,
}

@group(0) @binding(0) var depth: texture_depth_2d;
@group(0) @binding(1) var<storage, read> levels: array<Level>;
@group(0) @binding(2) var<storage, read_write> pyramid: array<f32>;
@group(0) @binding(3) var<uniform> step: Step;

@compute @workgroup_size(8, 8)
fn reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let dst = levels[step.level];
    if id.x >= dst.width || id.y >= dst.height {
        return;
    }
    var d: f32;
    if step.level == 0u {
        d = textureLoad(depth, vec2<i32>(id.xy), 0);
    } else {
        let src = levels[step.level - 1u];
        let x0 = min(2u * id.x, src.width - 1u);
        let x1 = min(2u * id.x + 1u, src.width - 1u);
        let y0 = min(2u * id.y, src.height - 1u);
        let y1 = min(2u * id.y + 1u, src.height - 1u);
        d = min(min(pyramid[src.offset + y0 * src.width + x0], pyramid[src.offset + y0 * src.width + x1]),
                min(pyramid[src.offset + y1 * src.width + x0], pyramid[src.offset + y1 * src.width + x1]));
    }
    pyramid[dst.offset + id.y * dst.width + id.x] = d;
}
