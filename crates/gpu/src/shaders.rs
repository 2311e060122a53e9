//! WGSL sources. WGSL has no includes: every shader is `common.wgsl` (the view uniform and
//! box layout) followed by its own file, so the shared structs are written once.

const COMMON: &str = include_str!("shaders/common.wgsl");

/// Every shader source hashed at compile time (FNV-1a): processes built from other shaders
/// draw other pixels, so the switch's handshake refuses a peer whose hash differs
/// (`osw_render::settings`) rather than let its frames differ silently.
pub const FINGERPRINT: u64 = fnv1a(&[
    COMMON,
    include_str!("shaders/draw.wgsl"),
    include_str!("shaders/item.frag.wgsl"),
    include_str!("shaders/place64.wgsl"),
    include_str!("shaders/place32.wgsl"),
    include_str!("shaders/boxtest.wgsl"),
    include_str!("shaders/boxcull.comp.wgsl"),
    include_str!("shaders/depthreduce.comp.wgsl"),
]);

/// 64-bit FNV-1a over the bytes of `sources` in turn.
const fn fnv1a(sources: &[&str]) -> u64 {
    let (mut h, mut i) = (0xcbf2_9ce4_8422_2325u64, 0);
    while i < sources.len() {
        let bytes = sources[i].as_bytes();
        let mut k = 0;
        while k < bytes.len() {
            h = (h ^ bytes[k] as u64).wrapping_mul(0x100_0000_01b3);
            k += 1;
        }
        i += 1;
    }
    h
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fingerprint_is_fnv1a_over_the_sources() {
        // FNV-1a's published test vectors.
        assert_eq!(fnv1a(&[""]), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(&["a"]), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(&["foo", "bar"]), fnv1a(&["foobar"]));
        assert_eq!(fnv1a(&["foobar"]), 0x8594_4171_f739_67e8);
        assert_ne!(FINGERPRINT, fnv1a(&[COMMON]), "every shader counts");
    }
}
