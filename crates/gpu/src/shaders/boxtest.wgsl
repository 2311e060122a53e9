// The HC box test (occlusion switch sec. 4.2): each instance rasterises one node's bounding box
// against the occluder depth buffer (depth test only, no writes). Early depth is forced so
// that only fragments that pass the test run the shader (without it lavapipe runs the shader
// for occluded fragments too, and the flags are wrong). count_pixels selects a per-box
// visible-pixel count (occlusion switch sec. 4.7.2) over a plain visible flag. A box whose lo.w is
// S > 1 counts only every S-th pixel line, starting at line hi.w and shifted by S/2 in every
// second span of 10 pixels: Bartz 1999 sec. 3.3's interleaved reading of the occlusion buffer.

override count_pixels: bool = false;

@group(0) @binding(0) var<uniform> view: ViewUniform;
@group(0) @binding(1) var<storage, read> boxes: array<Box>;
@group(0) @binding(2) var<storage, read_write> results: array<atomic<u32>>;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) box: u32,
    @location(1) @interpolate(flat) sampling: vec2<u32>,
}

// 12 triangles over the 8 corners (bit 0 = x, bit 1 = y, bit 2 = z), counter-clockwise seen
// from outside (the same faces as the generators' boxes): back faces are culled.
const CORNERS = array<u32, 36>(
    0u, 4u, 6u, 0u, 6u, 2u,  1u, 3u, 7u, 1u, 7u, 5u,
    0u, 1u, 5u, 0u, 5u, 4u,  2u, 6u, 7u, 2u, 7u, 3u,
    0u, 2u, 3u, 0u, 3u, 1u,  4u, 5u, 7u, 4u, 7u, 6u,
);

@vertex
fn vs_box(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> VertexOut {
    let b = boxes[instance];
    let c = CORNERS[vertex];
    let p = vec3<f32>(
        select(b.lo.x, b.hi.x, (c & 1u) != 0u),
        select(b.lo.y, b.hi.y, (c & 2u) != 0u),
        select(b.lo.z, b.hi.z, (c & 4u) != 0u),
    );
    var out: VertexOut;
    out.clip = view.view_proj * vec4<f32>(p, 1.0);
    out.box = instance;
    out.sampling = vec2<u32>(u32(b.lo.w), u32(b.hi.w));
    return out;
}

@fragment
@early_depth_test(force)
fn fs_box(in: VertexOut) {
    let s = in.sampling.x;
    if s > 1u {
        let shift = select(0u, s / 2u, ((u32(in.clip.x) / 10u) & 1u) == 1u);
        if (u32(in.clip.y) + shift) % s != in.sampling.y {
            return;
        }
    }
    if count_pixels {
        atomicAdd(&results[in.box], 1u);
    } else {
        atomicStore(&results[in.box], 1u);
    }
}
