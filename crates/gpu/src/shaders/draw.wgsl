// Draws LOD nodes: colour (RVG), depth only (OR) and, with item.frag.wgsl appended, item ids.
// Vertices are pulled: a pass index is (slot << view.draw.y) | vertex, the node's slot in the
// pass's use table and the vertex within its mesh in the arena (gpu/src/uses.rs). Positions
// are scene-local, made camera-relative by view.offset (precision far from the origin), or an
// instanced part's own, placed by its use's rows (`place`, from place64.wgsl or place32.wgsl,
// appended); view.view_proj is reversed Z with an infinite far plane. Colour passes start at
// vs_shade, which also reads the vertex's normal and texture coordinates from their arenas
// (bindings 3 and 4), filled only where the renderer shades: depth and item passes read
// positions alone. A textured surface's colour is sampled from the atlas (gpu/src/atlas.rs).

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
    // 1 where its mesh has texture coordinates in the texcoord arena, else 0.
    textured: u32,
    // Not a vec2 (aligned to 8): rows start at byte 32, as uses.rs writes them.
    pad: array<u32, 2>,
    rows: Rows,
}

@group(0) @binding(0) var<uniform> view: ViewUniform;
@group(0) @binding(1) var<storage, read> uses: array<Use>;
@group(0) @binding(2) var<storage, read> arena: array<Vertex>;
// A normal per arena vertex, octahedral (osw_scene::normal), NO_NORMAL where the mesh has none.
@group(0) @binding(3) var<storage, read> normals: array<u32>;
// Texture coordinates per arena vertex (osw_scene::texture::Texcoord).
@group(0) @binding(4) var<storage, read> texcoords: array<Texcoord>;
// The scene's textures (gpu/src/atlas.rs): where each one's levels lie in the atlas's pages.
@group(0) @binding(5) var<storage, read> textures: array<TextureInfo>;
@group(0) @binding(6) var<storage, read> rects: array<vec2<u32>>;
@group(0) @binding(7) var atlas: texture_2d_array<f32>;
// Bilinear, within a level: the gutter around each level holds what its wrap mode reads.
@group(0) @binding(8) var bilinear: sampler;

const NO_NORMAL: u32 = 0xffffffffu;
const NO_TEXTURE: u32 = 0xffffffffu;

// How a colour pipeline colours a textured surface: 0 not at all (its draws hold no textured
// triangle), 1 in each texture's mean colour, 2 sampled. A pipeline constant rather than a
// branch: lavapipe runs both sides of a branch for every pixel under a mask, so sampling code
// behind an untaken branch costs what sampling costs (measured).
override TEXTURES: u32 = 0u;

struct Texcoord {
    u: f32,
    v: f32,
    texture: u32,
}

// GpuTexture.
struct TextureInfo {
    rects: u32,
    // 0 where not resident: drawn in its mean colour.
    levels: u32,
    // log2 width | log2 height << 8.
    size: u32,
    // osw_scene::texture::Sampler::packed.
    sampler: u32,
    cutoff: f32,
    mean: u32,
    pad: vec2<u32>,
}

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
    @location(5) uv: vec2<f32>,
    @location(6) @interpolate(flat) texture: u32,
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
    out.uv = vec2<f32>(0.0);
    out.texture = NO_TEXTURE;
    return out;
}

@vertex
fn vs_shade(@builtin(vertex_index) index: u32) -> VertexOut {
    var out = vertex(index);
    let slot = index >> view.draw.y;
    let at = uses[slot].base + (index & ((1u << view.draw.y) - 1u));
    if (uses[slot].textured != 0u) {
        let t = texcoords[at];
        out.uv = vec2<f32>(t.u, t.v);
        out.texture = select(NO_TEXTURE, t.texture, t.texture < arrayLength(&textures));
    }
    if (uses[slot].normals == 0u) {
        return out;
    }
    let e = normals[at];
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

// A pixel's surface colour, sRGB-encoded, and its alpha: the model's colour times its texture
// where it samples one. Derivatives are taken here, in uniform control flow, before any branch.
fn surface(in: VertexOut) -> vec4<f32> {
    let flat = normalize(cross(dpdx(in.rel), dpdy(in.rel)));
    let dx = dpdx(in.uv);
    let dy = dpdy(in.uv);
    // The stored normal, else flat from the screen-space derivatives of the position.
    var n = flat;
    if (dot(in.normal, in.normal) > 1e-12) {
        n = normalize(in.normal);
    }
    var base = vec4<f32>(in.base, 1.0);
    if (in.color.a > 0.0) {
        base = in.color;
    }
    if (TEXTURES != 0u && in.texture != NO_TEXTURE) {
        // Products of sRGB-encoded values: within a rounding of products in linear light
        // (sRGB is close to a power law), as the light below is applied.
        base *= texel(textures[in.texture], in.uv, dx, dy);
    }
    if (view.draw.x != 0u) {
        base = vec4<f32>(unpack4x8unorm(view.draw.x).rgb, base.a);
    }
    let light = 0.35 + 0.65 * abs(dot(n, normalize(vec3<f32>(0.4, 0.8, 0.3))));
    return vec4<f32>(base.rgb * light, base.a);
}

// Opaque triangles and cut-outs: a cut-out's texel below its cutoff is a hole.
@fragment
fn fs_color(in: VertexOut) -> @location(0) vec4<f32> {
    let c = surface(in);
    if (TEXTURES != 0u && in.texture != NO_TEXTURE && c.a < textures[in.texture].cutoff) {
        discard;
    }
    return vec4<f32>(c.rgb, 1.0);
}

// Translucent triangles, blended with the model's alpha times the texture's.
@fragment
fn fs_blend(in: VertexOut) -> @location(0) vec4<f32> {
    return surface(in);
}

// Texture t at uv, sRGB-encoded with straight alpha: its mean where it is not resident or
// the pipeline samples none, else filtered as its sampler says (glTF 2.0 sec. 3.8.4), at the level
// that the footprint dx, dy of a pixel in uv asks for (the Vulkan spec's scale factor: the
// longer of the two axes' footprints in texels) or the one view.draw.z forces.
fn texel(t: TextureInfo, uv: vec2<f32>, dx: vec2<f32>, dy: vec2<f32>) -> vec4<f32> {
    if (t.levels == 0u || TEXTURES == 1u) {
        return unpack4x8unorm(t.mean);
    }
    let size = vec2<f32>(f32(1u << (t.size & 255u)), f32(1u << ((t.size >> 8u) & 255u)));
    var lod = log2(max(length(dx * size), length(dy * size)));
    if (view.draw.w != 0u) {
        lod = bitcast<f32>(view.draw.z);
    }
    let magnified = (t.sampler >> 8u) & 15u;
    let minified = (t.sampler >> 12u) & 15u;
    let mip = t.sampler >> 16u;
    var c: vec4<f32>;
    // NaN footprints (a degenerate triangle's pixel) read level 0.
    if (!(lod > 0.0) || mip == 0u) {
        c = level(t, 0u, uv, select(minified, magnified, !(lod > 0.0)));
    } else {
        let top = f32(t.levels - 1u);
        let l = clamp(lod, 0.0, top);
        if (mip == 1u) {
            // Nearest level: the Vulkan spec's ceil(lod + 0.5) - 1.
            c = level(t, u32(clamp(ceil(l + 0.5) - 1.0, 0.0, top)), uv, minified);
        } else {
            let k = u32(floor(l));
            let f = l - floor(l);
            c = mix(level(t, k, uv, minified), level(t, min(k + 1u, t.levels - 1u), uv, minified), f);
        }
    }
    return vec4<f32>(srgb(c.rgb), c.a);
}

// Level k of texture t at uv, nearest (linear 0) or bilinear, in linear light (the atlas's
// pages are sRGB: the texture unit decodes them before it filters). A bilinear footprint
// reaches half a texel past the wrapped coordinate's level into its gutter (gpu/src/atlas.rs).
fn level(t: TextureInfo, k: u32, uv: vec2<f32>, linear: u32) -> vec4<f32> {
    let size = vec2<i32>(max(vec2<u32>(1u), vec2<u32>(1u << (t.size & 255u), 1u << ((t.size >> 8u) & 255u)) >> vec2<u32>(k)));
    let r = rects[t.rects + k];
    let origin = vec2<i32>(i32(r.x & 0xffffu), i32(r.x >> 16u));
    let wrap = vec2<u32>(t.sampler & 15u, (t.sampler >> 4u) & 15u);
    let s = uv * vec2<f32>(size);
    if (linear == 0u) {
        return textureLoad(atlas, origin + wrapped(vec2<i32>(floor(s)), size, wrap), i32(r.y), 0);
    }
    let n = vec2<f32>(size);
    let w = vec2<f32>(wrap_coord(s.x, n.x, wrap.x), wrap_coord(s.y, n.y, wrap.y));
    let page = vec2<f32>(textureDimensions(atlas));
    return textureSampleLevel(atlas, bilinear, (vec2<f32>(origin) + w) / page, i32(r.y), 0.0);
}

// Coordinate s (in texels) along an axis of n texels, folded into 0..n: repeated (0), clamped
// to the edge texels' centres (1) or mirrored (2).
fn wrap_coord(s: f32, n: f32, mode: u32) -> f32 {
    let repeated = s - n * floor(s / n);
    let m = s - 2.0 * n * floor(s / (2.0 * n));
    let mirrored = select(m, 2.0 * n - m, m > n);
    return select(select(repeated, mirrored, mode == 2u), clamp(s, 0.5, n - 0.5), mode == 1u);
}

fn wrapped(i: vec2<i32>, size: vec2<i32>, wrap: vec2<u32>) -> vec2<i32> {
    return vec2<i32>(wrap_axis(i.x, size.x, wrap.x), wrap_axis(i.y, size.y, wrap.y));
}

// Texel i of n along an axis: repeated (0), clamped to the edge (1) or mirrored (2).
fn wrap_axis(i: i32, n: i32, mode: u32) -> i32 {
    if (mode == 1u) {
        return clamp(i, 0, n - 1);
    }
    if (mode == 2u) {
        let m = ((i % (2 * n)) + 2 * n) % (2 * n);
        return select(m, 2 * n - 1 - m, m >= n);
    }
    return ((i % n) + n) % n;
}

// Linear light as sRGB-encoded (IEC 61966-2-1).
fn srgb(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    return select(1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055, 12.92 * x, x <= vec3<f32>(0.0031308));
}
