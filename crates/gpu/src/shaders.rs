//! WGSL sources. WGSL has no includes: every shader is `common.wgsl` (the view uniform and
//! box layout) followed by its own file, so the shared structs are written once.

const COMMON: &str = include_str!("shaders/common.wgsl");

/// `common.wgsl` + `body`, with `enables` (WGSL `enable` directives must come first).
pub fn source(enables: &str, body: &str) -> String {
    format!("{enables}{COMMON}\n{body}")
}

/// A shader module from [`source`].
pub fn module(device: &wgpu::Device, label: &str, enables: &str, body: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source(enables, body).into()),
    })
}
