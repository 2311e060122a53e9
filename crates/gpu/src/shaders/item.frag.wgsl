// Item buffer (occlusion switch sec. 5, exact visibility): node id + 1 (0 = background) and the
// triangle's index within the pass's one draw (distinct per triangle). Appended to draw.wgsl.

@fragment
fn fs_item(in: VertexOut, @builtin(primitive_index) primitive: u32) -> @location(0) vec2<u32> {
    return vec2<u32>(in.node + 1u, primitive);
}
