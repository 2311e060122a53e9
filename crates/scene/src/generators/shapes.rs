//! Mesh primitives for the generators. Every shape is closed where it says so and wound
//! counter-clockwise seen from outside, so back-face culling is valid on generated scenes.
//! Pole rings of a lathe repeat one vertex; the degenerate triangles that makes are dropped by
//! the build's clean-up like any input's.

use crate::mesh::Mesh;
use glam::Vec3;
use std::f32::consts::TAU;

fn quad(m: &mut Mesh, a: u32, b: u32, c: u32, d: u32) {
    m.indices.extend([a, b, c, a, c, d]);
}

/// A closed box from `min` to `max`: 8 vertices, 12 triangles.
pub fn add_box(m: &mut Mesh, min: Vec3, max: Vec3) {
    let base = m.positions.len() as u32;
    for i in 0..8 {
        let pick = |bit: u32, lo: f32, hi: f32| if i & bit != 0 { hi } else { lo };
        m.positions.push([pick(1, min.x, max.x), pick(2, min.y, max.y), pick(4, min.z, max.z)]);
    }
    for [a, b, c, d] in [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]] {
        quad(m, base + a, base + b, base + c, base + d);
    }
}

/// A horizontal plane at `min.y` from `min` to `max` facing +y, as an `nx` by `nz` grid of quads.
pub fn grid_plane(m: &mut Mesh, min: Vec3, max: Vec3, nx: u32, nz: u32) {
    let (nx, nz) = (nx.max(1), nz.max(1));
    let base = m.positions.len() as u32;
    for i in 0..=nx {
        for k in 0..=nz {
            let x = min.x + (max.x - min.x) * i as f32 / nx as f32;
            let z = min.z + (max.z - min.z) * k as f32 / nz as f32;
            m.positions.push([x, min.y, z]);
        }
    }
    let at = |i: u32, k: u32| base + i * (nz + 1) + k;
    for i in 0..nx {
        for k in 0..nz {
            quad(m, at(i, k), at(i, k + 1), at(i + 1, k + 1), at(i + 1, k));
        }
    }
}

/// A surface of revolution about the vertical axis through `center`: `profile` is (radius,
/// height) from bottom to top; a radius of 0 is a pole (one vertex) that closes the surface.
pub fn lathe(m: &mut Mesh, center: Vec3, profile: &[(f32, f32)], segments: u32) {
    let s = segments.max(3);
    let mut ring_base = Vec::with_capacity(profile.len());
    for &(r, y) in profile {
        ring_base.push(m.positions.len() as u32);
        let count = if r == 0.0 { 1 } else { s };
        for j in 0..count {
            let a = TAU * j as f32 / s as f32;
            m.positions.push((center + Vec3::new(r * a.cos(), y, r * a.sin())).to_array());
        }
    }
    let at = |i: usize, j: u32| if profile[i].0 == 0.0 { ring_base[i] } else { ring_base[i] + j % s };
    for i in 0..profile.len().saturating_sub(1) {
        let (pole_lo, pole_hi) = (profile[i].0 == 0.0, profile[i + 1].0 == 0.0);
        for j in 0..s {
            // The quad's two triangles; at a pole one of them collapses and is left out.
            if !pole_hi {
                m.indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            }
            if !pole_lo {
                m.indices.extend([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
}

/// Profile of a sphere of radius `r` resting on y = 0, with `rings` rings from pole to pole.
pub fn sphere_profile(r: f32, rings: u32) -> Vec<(f32, f32)> {
    let ring = |i: u32| {
        let p = std::f32::consts::PI * i as f32 / rings as f32;
        // Exact zeros at the poles: sin(pi) in f32 is not 0.
        let radius = if i == 0 || i == rings { 0.0 } else { r * p.sin() };
        (radius, r * (1.0 - p.cos()))
    };
    (0..=rings).map(ring).collect()
}

/// A tube of `radius` swept along the polyline `points` (at least 2, no repeated points), with
/// `segments` around; `caps` closes both ends. Frames are parallel-transported along the path.
pub fn tube(m: &mut Mesh, points: &[Vec3], radius: f32, segments: u32, caps: bool) {
    if points.len() < 2 {
        return;
    }
    let s = segments.max(3);
    let base = m.positions.len() as u32;
    let tangent = |i: usize| {
        let a = points[i.saturating_sub(1)];
        let b = points[(i + 1).min(points.len() - 1)];
        (b - a).normalize_or(Vec3::Y)
    };
    let mut n = tangent(0).any_orthonormal_vector();
    for (i, &p) in points.iter().enumerate() {
        let t = tangent(i);
        n = (n - t * n.dot(t)).normalize_or(t.any_orthonormal_vector());
        let b = t.cross(n);
        for j in 0..s {
            let a = TAU * j as f32 / s as f32;
            m.positions.push((p + radius * (a.cos() * n + a.sin() * b)).to_array());
        }
    }
    let at = |i: u32, j: u32| base + i * s + j % s;
    for i in 0..points.len() as u32 - 1 {
        for j in 0..s {
            quad(m, at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
        }
    }
    if caps {
        let last = points.len() as u32 - 1;
        let c0 = m.positions.len() as u32;
        m.positions.push(points[0].to_array());
        m.positions.push(points[last as usize].to_array());
        for j in 0..s {
            m.indices.extend([c0, at(0, j + 1), at(0, j)]);
            m.indices.extend([c0 + 1, at(last, j), at(last, j + 1)]);
        }
    }
}

/// A closed cylinder from `a` to `b`.
pub fn cylinder(m: &mut Mesh, a: Vec3, b: Vec3, radius: f32, segments: u32) {
    tube(m, &[a, b], radius, segments, true);
}

/// `corners` with every inner corner replaced by a quadratic arc of `arc_points` points
/// starting `bend` before the corner (elbows of a pipe run).
pub fn rounded(corners: &[Vec3], bend: f32, arc_points: u32) -> Vec<Vec3> {
    let mut out = vec![corners[0]];
    for w in corners.windows(3) {
        let (a, c, b) = (w[0], w[1], w[2]);
        let r = bend.min(0.45 * (c - a).length()).min(0.45 * (b - c).length());
        let p0 = c + (a - c).normalize_or_zero() * r;
        let p2 = c + (b - c).normalize_or_zero() * r;
        for k in 0..=arc_points {
            let t = k as f32 / arc_points as f32;
            out.push(p0 * (1.0 - t) * (1.0 - t) + c * 2.0 * t * (1.0 - t) + p2 * t * t);
        }
    }
    out.push(*corners.last().expect("at least one corner"));
    out.dedup_by(|a, b| a.distance_squared(*b) < 1e-12);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sum over triangles of (centroid - inside point) . normal: positive when every triangle
    /// faces away from `inside`.
    fn faces_outward(m: &Mesh, inside: Vec3) -> bool {
        m.indices.chunks_exact(3).all(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| m.vertex(i));
            let n = (b - a).cross(c - a);
            n.length_squared() == 0.0 || ((a + b + c) / 3.0 - inside).dot(n) > 0.0
        })
    }

    #[test]
    fn shapes_face_outward() {
        let mut m = Mesh::default();
        add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        assert_eq!(m.triangle_count(), 12);
        assert!(faces_outward(&m, Vec3::splat(0.5)));
        let mut m = Mesh::default();
        cylinder(&mut m, Vec3::ZERO, Vec3::new(1.0, 2.0, 0.5), 0.3, 12);
        assert!(faces_outward(&m, Vec3::new(0.5, 1.0, 0.25)));
        let mut m = Mesh::default();
        lathe(&mut m, Vec3::ZERO, &sphere_profile(1.0, 8), 12);
        assert!(faces_outward(&m, Vec3::Y));
        let mut m = Mesh::default();
        grid_plane(&mut m, Vec3::ZERO, Vec3::new(2.0, 0.0, 2.0), 2, 2);
        assert!(faces_outward(&m, Vec3::new(1.0, -1.0, 1.0)));
    }

    #[test]
    fn rounded_corner_stays_between_its_legs() {
        let pts = rounded(&[Vec3::ZERO, Vec3::X * 4.0, Vec3::new(4.0, 4.0, 0.0)], 1.0, 4);
        assert_eq!(pts.first(), Some(&Vec3::ZERO));
        assert_eq!(pts.last(), Some(&Vec3::new(4.0, 4.0, 0.0)));
        assert!(pts.iter().all(|p| p.x <= 4.0 && p.y >= 0.0));
    }
}
