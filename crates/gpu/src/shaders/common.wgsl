// Shared by every shader (prepended by shaders::source): the view uniform, the box layout and
// the depth pyramid's level table.
// Positions are camera-relative: view.offset is added to scene-local positions.

struct ViewUniform {
    view_proj: mat4x4<f32>,
    offset: vec4<f32>,
    // x: the draw pass's tint, y: its use table's shift, z: a texture level, forced where w is 1
    // (draw.wgsl, gpu/src/draw.rs).
    draw: vec4<u32>,
}

// A camera-relative box (32 bytes, GpuBox on the CPU).
struct Box {
    lo: vec4<f32>,
    hi: vec4<f32>,
}

// One level of the packed depth pyramid (pyramid::Level on the CPU).
struct Level {
    offset: u32,
    width: u32,
    height: u32,
    // Texels from one row to the next (level 0: rows padded for the copy from the texture).
    pitch: u32,
}
