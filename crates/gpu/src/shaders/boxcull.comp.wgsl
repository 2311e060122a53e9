// The pyramid box test (conservative, Peng 2014 eq. 4 on the GPU): each invocation projects
// one camera-relative box, takes the level where its screen rectangle spans at most
// 2^(1 + finer) texels a side, and compares the box's nearest depth with the farthest occluder
// depth over the texels covering the rectangle. Same rule as osw-cull's HzbTester (the CPU
// reference). finer = 0 is Peng 2014's 2x2 texels; each step finer reads four times the texels and
// culls more. Set from osw_cull::hzb::PYRAMID_FINER when the pipeline is made.

override finer: u32;

struct Batch {
    count: u32,
    level_count: u32,
}

@group(0) @binding(0) var<uniform> view: ViewUniform;
@group(0) @binding(1) var<storage, read> boxes: array<Box>;
@group(0) @binding(2) var<storage, read_write> results: array<u32>;
@group(0) @binding(3) var<storage, read> levels: array<Level>;
@group(0) @binding(4) var<storage, read> pyramid: array<f32>;
@group(0) @binding(5) var<uniform> batch: Batch;

@compute @workgroup_size(64)
fn cull(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= batch.count {
        return;
    }
    let b = boxes[i];
    let size = vec2<f32>(f32(levels[0].width), f32(levels[0].height));
    var lo = vec2<f32>(1e30, 1e30);
    var hi = vec2<f32>(-1e30, -1e30);
    var nearest = 0.0;
    for (var c = 0u; c < 8u; c++) {
        let p = vec3<f32>(select(b.lo.x, b.hi.x, (c & 1u) != 0u), select(b.lo.y, b.hi.y, (c & 2u) != 0u), select(b.lo.z, b.hi.z, (c & 4u) != 0u));
        let clip = view.view_proj * vec4<f32>(p, 1.0);
        if clip.w <= 0.0 {
            results[i] = 0xffffffffu;
            return;
        }
        let ndc = clip.xyz / clip.w;
        let px = vec2<f32>((ndc.x + 1.0) * 0.5, (1.0 - ndc.y) * 0.5) * size;
        lo = min(lo, px);
        hi = max(hi, px);
        nearest = max(nearest, ndc.z);
    }
    if hi.x < 0.0 || hi.y < 0.0 || lo.x >= size.x || lo.y >= size.y {
        results[i] = 0u;
        return;
    }
    let p0 = vec2<u32>(clamp(floor(lo), vec2<f32>(0.0), size - 1.0));
    let p1 = vec2<u32>(clamp(floor(hi), vec2<f32>(0.0), size - 1.0));
    let span = max(p1.x - p0.x, p1.y - p0.y) + 1u;
    // Level where the rectangle spans at most 2^(1 + finer) texels: ceil(log2(span)) - finer,
    // in closed form.
    var s = 0u;
    if span > 1u {
        s = firstLeadingBit(span - 1u) + 1u;
    }
    s = min(s - min(s, finer), batch.level_count - 1u);
    let l = levels[s];
    let t0 = p0 >> vec2<u32>(s);
    let t1 = min(p1 >> vec2<u32>(s), vec2<u32>(l.width - 1u, l.height - 1u));
    var far = 1e30;
    for (var y = t0.y; y <= t1.y; y++) {
        for (var x = t0.x; x <= t1.x; x++) {
            far = min(far, pyramid[l.offset + y * l.pitch + x]);
        }
    }
    // The same rounding margin as the CPU reference. A visible box reports 1 + the level it
    // was read at, so that the hybrid test can send small boxes on to the exact test.
    results[i] = select(0u, 1u + s, nearest >= far - 1e-7);
}
