//! Vertex normals, stored octahedral in 4 bytes (two snorm16, Cigolle et al., "A Survey of
//! Efficient Representations for Independent Unit Vectors", JCGT 2014). Normals shade; they
//! are never a test on geometry (cluster cones and back-face tests use the triangles
//! themselves). [`crate::smooth`] computes them where a model gives none.

use glam::{DMat3, Vec3};

/// A unit normal, octahedral: x in the low 16 bits, y in the high, snorm16 each (WGSL's
/// `unpack2x16snorm`).
pub type Normal = u32;

/// A vertex without a normal (a mesh merged with one that has them): shaded flat. No encoded
/// unit vector is this value ([`encode`] avoids it).
pub const NO_NORMAL: Normal = u32::MAX;

pub fn encode(n: Vec3) -> Normal {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs());
    let (x, y) = if n.z >= 0.0 { (n.x, n.y) } else { ((1.0 - n.y.abs()) * n.x.signum(), (1.0 - n.x.abs()) * n.y.signum()) };
    let q = |v: f32| (v.clamp(-1.0, 1.0) * 32767.0).round() as i16 as u16 as u32;
    let e = q(x) | (q(y) << 16);
    // (-1/32767, -1/32767): (0, 0, 1) within 4e-5 rad.
    if e == NO_NORMAL { 0 } else { e }
}

/// A normal read from a model: encoded, or [`NO_NORMAL`] (computed at the build) where it has
/// zero length or is not finite.
pub fn given(n: Vec3) -> Normal {
    if n.is_finite() && n.length_squared() > 0.0 { encode(n) } else { NO_NORMAL }
}

pub fn decode(e: Normal) -> Vec3 {
    let s = |v: u32| (v as u16 as i16 as f32 / 32767.0).max(-1.0);
    let (x, y) = (s(e), s(e >> 16));
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    Vec3::new(x - t * x.signum(), y - t * y.signum(), z).normalize()
}

/// `normals` turned with the surface under the linear map `m`: by its inverse transpose,
/// which keeps a normal perpendicular to its surface under scaling and shear (the cofactor
/// matrix, the inverse transpose times the determinant, signed back so that a mirror keeps
/// outward normals outward).
pub fn transform(normals: &mut [Normal], m: DMat3) {
    if normals.is_empty() || m == DMat3::IDENTITY {
        return;
    }
    let c = DMat3::from_cols(m.y_axis.cross(m.z_axis), m.z_axis.cross(m.x_axis), m.x_axis.cross(m.y_axis)) * m.determinant().signum();
    for n in normals.iter_mut().filter(|n| **n != NO_NORMAL) {
        let turned = (c * decode(*n).as_dvec3()).as_vec3();
        if turned.length_squared() > 0.0 && turned.is_finite() {
            *n = encode(turned);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encoding_keeps_a_direction_within_a_ten_thousandth() {
        let mut worst = 0.0f32;
        for i in 0..2000 {
            // A spiral over the sphere, and the axes and octants' edges.
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 2000.0;
            let a = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            for n in [Vec3::new(r * a.cos(), r * a.sin(), z), Vec3::X, -Vec3::Z, Vec3::new(1.0, -1.0, 0.0).normalize()] {
                let e = encode(n);
                assert_ne!(e, NO_NORMAL);
                // The sine: acos in f32 cannot tell angles below 5e-4 rad.
                worst = worst.max(decode(e).cross(n).length());
            }
        }
        assert!(worst < 1e-4, "{worst} rad");
        assert_eq!(encode(Vec3::new(-3.05e-5, -3.05e-5, 1.0)), 0, "the reserved value is not produced");
    }
}
