// Draws LOD nodes: colour (RVG), depth only (OR) and, with item.frag.wgsl appended, item ids.
// Vertices are pulled: a pass index is (slot << view.draw.y) | vertex, the node's slot in the
// pass's use table and the vertex within its mesh in the arena (gpu/src/uses.rs). Positions
// are scene-local, made camera-relative by view.offset (precision far from the origin), or an
// instanced part's own, placed by its use's rows (`place`, from place64.wgsl or place32.wgsl,
// appended); view.view_proj is reversed Z with an infinite far plane. Colour passes start at
// vs_shade, which also reads the vertex's normal from the normal arena (binding 3), filled only
// where the renderer shades: depth and item passes read positions alone.

// The mesh vertex in the arena (ArenaVertex).
struct Vertex {
    position: vec3<f32>,
    // The model's colour (RGBA8), alpha 0 where it has none.
    color: u32,
}

// One node of the pass (gpu/src/uses.rs).
struct Use {
    node: u32,
    base: u32,
    placed: u32,
    // The node's object, for its colour.
    object: u32,
    // 1 where its mesh has normals in the normal arena, else 0 (shaded flat).
    normals: u32,
    // Not a vec3 (aligned to 16): rows start at byte 32, as uses.rs writes them.
    pad: array<u32, 3>,
    rows: Rows,
}

@group(0) @binding(0) var<uniform> view: ViewUniform;
@group(0) @binding(1) var<storage, read> uses: array<Use>;
@group(0) @binding(2) var<storage, read> arena: array<Vertex>;
// A normal per arena vertex, octahedral (osw_scene::normal), NO_NORMAL where the mesh has none.
@group(0) @binding(3) var<storage, read> normals: array<u32>;

const NO_NORMAL: u32 = 0xffffffffu;

struct VertexOut {
    // Invariant: the colour, depth and item pipelines compute the same depth for a vertex, so
    // that prev's RVG over OR's depth (GreaterEqual) passes the surface OR drew.
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) rel: vec3<f32>,
    @location(1) @interpolate(flat) node: u32,
    // The model's colour; alpha 0 where it has none, below 1 where it is translucent.
    @location(2) color: vec4<f32>,
    // The object's colour (or the pass's tint), the same at every vertex of a node: made once
    // per vertex rather than per pixel (lavapipe shades on the CPU; measured).
    @location(3) @interpolate(flat) base: vec3<f32>,
    // The surface's normal, camera-relative frame; zero where it has none (shaded flat).
    @location(4) normal: vec3<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> VertexOut {
    return vertex(index);
}

fn vertex(index: u32) -> VertexOut {
    let shift = view.draw.y;
    // Field by field: a unique node's vertex reads 16 bytes of its use, not 128.
    let slot = index >> shift;
    let node = uses[slot].node;
    let v = arena[uses[slot].base + (index & ((1u << shift) - 1u))];
    var rel = v.position + view.offset.xyz;
    if (uses[slot].placed != 0u) {
        rel = place(uses[slot].rows, v.position);
    }
    var out: VertexOut;
    out.clip = view.view_proj * vec4<f32>(rel, 1.0);
    out.rel = rel;
    out.node = node;
    out.color = unpack4x8unorm(v.color);
    let h = hash(uses[slot].object);
    out.base = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0 * 0.6 + 0.3;
    out.normal = vec3<f32>(0.0);
    return out;
}

@vertex
fn vs_shade(@builtin(vertex_index) index: u32) -> VertexOut {
    var out = vertex(index);
    let slot = index >> view.draw.y;
    if (uses[slot].normals == 0u) {
        return out;
    }
    let e = normals[uses[slot].base + (index & ((1u << view.draw.y) - 1u))];
    if (e != NO_NORMAL) {
        out.normal = octahedral(e);
        if (uses[slot].placed != 0u) {
            out.normal = turned(linear_rows(uses[slot].rows), out.normal);
        }
    }
    return out;
}

// Cigolle et al. 2014's octahedral decoding (osw_scene::normal::decode).
fn octahedral(e: u32) -> vec3<f32> {
    let f = unpack2x16snorm(e);
    var n = vec3<f32>(f, 1.0 - abs(f.x) - abs(f.y));
    let t = max(-n.z, 0.0);
    n.x -= t * sign(n.x);
    n.y -= t * sign(n.y);
    return normalize(n);
}

// A normal under the linear map of rows a, b, c: by its inverse transpose, as the rows' cofactors
// (osw_scene::normal::transform), signed so that a mirror keeps it outward; zero (shaded flat)
// under a map that flattens the surface. Under a translation alone it is the normal itself, bit
// for bit, as a placed copy's is.
fn turned(r: array<vec3<f32>, 3>, n: vec3<f32>) -> vec3<f32> {
    if (all(r[0] == vec3<f32>(1.0, 0.0, 0.0)) && all(r[1] == vec3<f32>(0.0, 1.0, 0.0)) && all(r[2] == vec3<f32>(0.0, 0.0, 1.0))) {
        return n;
    }
    let c = vec3<f32>(dot(cross(r[1], r[2]), n), dot(cross(r[2], r[0]), n), dot(cross(r[0], r[1]), n));
    let l = length(c);
    return select(vec3<f32>(0.0), c / l * sign(dot(r[0], cross(r[1], r[2]))), l > 0.0);
}

// PCG hash: a stable colour per object.
fn hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn shade(in: VertexOut) -> vec3<f32> {
    // The stored normal, else flat from the screen-space derivatives of the position (taken
    // outside the branch: derivatives need every pixel of the quad).
    let flat = normalize(cross(dpdx(in.rel), dpdy(in.rel)));
    var n = flat;
    if (dot(in.normal, in.normal) > 1e-12) {
        n = normalize(in.normal);
    }
    var base = in.base;
    if (in.color.a > 0.0) {
        base = in.color.rgb;
    }
    if (view.draw.x != 0u) {
        base = unpack4x8unorm(view.draw.x).rgb;
    }
    let light = 0.35 + 0.65 * abs(dot(n, normalize(vec3<f32>(0.4, 0.8, 0.3))));
    return base * light;
}

@fragment
fn fs_color(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(shade(in), 1.0);
}

// Translucent triangles, blended with the model's alpha.
@fragment
fn fs_blend(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(shade(in), in.color.a);
}
