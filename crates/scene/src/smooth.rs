//! Normals where a model gives none: computed at the build, split at creases; and a build's
//! choice of normals ([`Normals`]).

use crate::mesh::Mesh;
use crate::normal::{NO_NORMAL, Normal, decode, encode};
use glam::Vec3;

/// The crease angle by default, degrees: faces meeting at a sharper angle keep their own
/// normals at the edge. A CAD box (90°) and an octagonal prism (45°) stay faceted, a pipe of
/// twelve or more facets (30° or less) shades round.
pub const CREASE_DEGREES: f32 = 40.0;

/// What a build does about normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Normals {
    /// None stored: every surface shaded flat, from its depth's screen-space derivatives.
    Flat,
    /// The model's where it gives them, else computed with creases at this angle (degrees).
    Smooth { crease_degrees: f32 },
}

impl Default for Normals {
    fn default() -> Normals {
        Normals::Smooth { crease_degrees: CREASE_DEGREES }
    }
}

impl std::fmt::Display for Normals {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            Normals::Flat => f.write_str("flat"),
            Normals::Smooth { crease_degrees } => write!(f, "smooth, creases at {crease_degrees}°"),
        }
    }
}

impl Normals {
    /// `mesh` with a normal at every vertex, or with none ([`Normals::Flat`]).
    pub fn apply(self, mut mesh: Mesh) -> Mesh {
        match self {
            Normals::Flat => {
                mesh.normals = Vec::new();
                mesh
            }
            Normals::Smooth { crease_degrees } => computed(mesh, crease_degrees.to_radians().cos()),
        }
    }
}

/// A normal within this cosine of its face's shades as the face itself: about 1.4e-3 rad, a
/// thousandth of the light's range.
const FLAT_COS: f32 = 1.0 - 1e-6;

/// `mesh` with its missing normals computed: at a corner, the sum of the corners at the same
/// position whose faces turn from its own by less than the crease (cosine `crease_cos`), each
/// weighted by its face's area and its angle at the corner (Thürmer and Wüthrich 1998: a
/// normal independent of how the surface is cut into triangles). Given normals are kept.
///
/// A triangle whose three normals are its face's stores none ([`NO_NORMAL`]): the shader's
/// flat normal from the depth's derivatives is the same, so a box's corners stay one vertex
/// each rather than three, and a model of flat faces stores no normals at all. Elsewhere a
/// vertex is split where its faces fall on two sides of a crease; vertices of one position,
/// colour and normal are one.
fn computed(mesh: Mesh, crease_cos: f32) -> Mesh {
    if mesh.is_empty() {
        return mesh;
    }
    let faces: Vec<Vec3> = mesh
        .indices
        .chunks_exact(3)
        .map(|t| (mesh.vertex(t[1]) - mesh.vertex(t[0])).cross(mesh.vertex(t[2]) - mesh.vertex(t[0])))
        .collect();
    let unit: Vec<Vec3> = faces.iter().map(|f| f.normalize_or_zero()).collect();
    let around = Around::of(&mesh);
    let weighted = |c: usize| {
        let (t, k) = (c / 3 * 3, c % 3);
        let p = mesh.vertex(mesh.indices[t + k]);
        let (a, b) = (mesh.vertex(mesh.indices[t + (k + 1) % 3]) - p, mesh.vertex(mesh.indices[t + (k + 2) % 3]) - p);
        faces[c / 3] * a.angle_between(b)
    };
    let corner = |(c, &v): (usize, &u32)| match mesh.normals.get(v as usize) {
        Some(&n) if n != NO_NORMAL => n,
        _ => {
            let own = unit[c / 3];
            let near = around.corners(v).iter().filter(|&&o| unit[o as usize / 3].dot(own) >= crease_cos);
            let sum: Vec3 = near.map(|&o| weighted(o as usize)).sum();
            encode(if sum.length_squared() > 0.0 {
                sum
            } else if own != Vec3::ZERO {
                own
            } else {
                Vec3::Y
            })
        }
    };
    let mut normals: Vec<Normal> = mesh.indices.iter().enumerate().map(corner).collect();
    for (t, n) in normals.chunks_exact_mut(3).enumerate() {
        if n.iter().all(|&n| decode(n).dot(unit[t]) >= FLAT_COS) {
            n.fill(NO_NORMAL);
        }
    }
    let flat = normals.iter().all(|&n| n == NO_NORMAL);
    Mesh {
        positions: per_corner(&mesh.positions, &mesh.indices),
        colors: per_corner(&mesh.colors, &mesh.indices),
        normals: if flat { Vec::new() } else { normals },
        single_sided: per_corner(&mesh.single_sided, &mesh.indices),
        texcoords: per_corner(&mesh.texcoords, &mesh.indices),
        indices: (0..mesh.indices.len() as u32).collect(),
    }
    .welded()
}

/// A vertex attribute per corner of `indices` (none where the mesh has none).
fn per_corner<T: Copy>(attribute: &[T], indices: &[u32]) -> Vec<T> {
    if attribute.is_empty() { Vec::new() } else { indices.iter().map(|&i| attribute[i as usize]).collect() }
}

/// A mesh's corners by position: vertices split by colour or normal still meet there.
struct Around {
    /// Per vertex, its position's group.
    group: Vec<u32>,
    /// Corners of group g: `corners[start[g]..start[g + 1]]`.
    start: Vec<u32>,
    corners: Vec<u32>,
}

impl Around {
    fn of(mesh: &Mesh) -> Around {
        let keys: Vec<[u32; 3]> = mesh.positions.iter().map(|p| p.map(f32::to_bits)).collect();
        let (groups, group) = meshopt::generate_vertex_remap(&keys, Some(&mesh.indices));
        let mut start = vec![0u32; groups + 1];
        mesh.indices.iter().for_each(|&v| start[group[v as usize] as usize + 1] += 1);
        (0..groups).for_each(|g| start[g + 1] += start[g]);
        let mut fill = start.clone();
        let mut corners = vec![0u32; mesh.indices.len()];
        for (c, &v) in mesh.indices.iter().enumerate() {
            let g = group[v as usize] as usize;
            corners[fill[g] as usize] = c as u32;
            fill[g] += 1;
        }
        Around { group, start, corners }
    }

    /// The corners at vertex `v`'s position.
    fn corners(&self, v: u32) -> &[u32] {
        let g = self.group[v as usize] as usize;
        &self.corners[self.start[g] as usize..self.start[g + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;

    #[test]
    fn a_box_stores_no_normals_and_a_pipe_is_round() {
        let mut cube = Mesh::default();
        shapes::add_box(&mut cube, Vec3::ZERO, Vec3::ONE);
        let cube = Normals::default().apply(cube);
        assert!(cube.normals.is_empty(), "flat faces shade flat");
        assert_eq!(cube.positions.len(), 8);
        let mut pipe = Mesh::default();
        shapes::tube(&mut pipe, &[Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0)], 1.0, 32, false);
        let pipe = Normals::default().apply(pipe);
        // Every vertex on the mantle points away from the axis, along the radius.
        for (v, p) in pipe.positions.iter().enumerate() {
            let p = Vec3::from_array(*p);
            let radial = Vec3::new(p.x, p.y, 0.0).normalize();
            assert!(decode(pipe.normals[v]).dot(radial) > 0.999, "vertex {v} at {p}");
        }
        // An octagonal prism keeps its edges: each face's corners take the face's normal, so
        // every triangle is flat.
        let mut prism = Mesh::default();
        shapes::tube(&mut prism, &[Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0)], 1.0, 8, false);
        assert!(Normals::default().apply(prism).normals.is_empty());
    }

    #[test]
    fn given_normals_are_kept_and_only_the_missing_computed() {
        let mut m = Mesh::default();
        m.push_triangle(Vec3::ZERO, Vec3::X, Vec3::Y);
        m.push_triangle(Vec3::X, Vec3::ONE, Vec3::Y);
        let bent = encode(Vec3::new(1.0, 0.0, 1.0));
        m.normals = vec![bent, NO_NORMAL, bent, NO_NORMAL, NO_NORMAL, NO_NORMAL];
        let m = Normals::default().apply(m);
        let of = |p: Vec3| {
            let t = m.indices.chunks_exact(3).find(|t| t.iter().any(|&v| m.vertex(v) == p)).unwrap();
            t.iter().map(|&v| m.normals[v as usize]).collect::<Vec<_>>()
        };
        // The bent triangle: its two given normals, and the computed one of its plane.
        let first = of(Vec3::ZERO);
        assert_eq!(first.iter().filter(|&&n| n == bent).count(), 2, "{first:?}");
        assert!(first.iter().any(|&n| n != bent && decode(n).dot(Vec3::Z) > 0.9999));
        // The other, flat: none stored.
        assert_eq!(of(Vec3::ONE), vec![NO_NORMAL; 3]);
        assert!(Normals::Flat.apply(m).normals.is_empty());
    }
}
