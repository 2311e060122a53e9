//! Repeats the input does not name: an object whose mesh equals an earlier object's up to a
//! translation (OBJ groups, PLY files, a glTF exported without reusing its meshes, every copy
//! written out in world coordinates) is found by its content and stored as a use of one mesh,
//! as the meshes the input names are ([`crate::stream`]).
//!
//! The content is the mesh in its own frame, its box's low corner at the origin: indices,
//! colours and positions, each position the exact f64 difference of two f32 world points. 128
//! bits of xxh3 name it, as they name the meshes the input names, so copies are equal to the
//! bit, not near: moved by a translation that the file's coordinates hold exactly (a CAD
//! export in millimetres, copies a whole grid step apart), not copies whose coordinates were
//! rounded apart far from the origin, and not copies scaled, mirrored or turned.

use crate::limits::LOD_MIN_TRIANGLES;
use crate::mesh::Object;
use glam::DVec3;

/// A mesh found in its own frame: the name of its content, where its frame lies in the world
/// (its box's low corner), and its positions relative to that corner (its indices and
/// colours are the object's).
pub struct Translated {
    pub content: u128,
    pub corner: DVec3,
    pub positions: Vec<[f32; 3]>,
}

/// `o`'s mesh in its own frame, or None where it is not worth a use: at most
/// LOD_MIN_TRIANGLES triangles (an instance record and its nodes cost about what storing it
/// does).
pub fn translated(o: &Object) -> Option<Translated> {
    if o.mesh.triangle_count() <= LOD_MIN_TRIANGLES as usize {
        return None;
    }
    let mut relative: Vec<[f64; 3]> = o.mesh.positions.iter().map(|&p| o.world(p).to_array()).collect();
    let corner = relative.iter().fold(DVec3::INFINITY, |lo, &p| lo.min(DVec3::from(p)));
    if !corner.is_finite() {
        return None;
    }
    relative.iter_mut().for_each(|p| *p = (DVec3::from(*p) - corner).to_array());
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    h.update(&(relative.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(&relative));
    h.update(bytemuck::cast_slice(&o.mesh.indices));
    h.update(o.mesh.colors.as_flattened());
    h.update(bytemuck::cast_slice(&o.mesh.normals));
    h.update(bytemuck::cast_slice(&o.mesh.texcoords));
    let positions = relative.iter().map(|&p| DVec3::from(p).as_vec3().to_array()).collect();
    Some(Translated { content: h.digest128(), corner, positions })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;
    use crate::mesh::Mesh;
    use glam::{DAffine3, Vec3};

    /// A sphere whose coordinates are multiples of 2^-10, as a file in fixed precision holds
    /// them: moved by a multiple of 2^-10 under 2^13, every coordinate stays exact in f32.
    fn sphere() -> Mesh {
        let mut m = Mesh::default();
        shapes::lathe(&mut m, Vec3::ZERO, &shapes::sphere_profile(0.7, 8), 16);
        m.positions.iter_mut().for_each(|p| *p = p.map(|c| (c * 1024.0).round() / 1024.0));
        m
    }

    /// `m` written out at `at` in world coordinates, rounded to f32 as a file would hold it.
    fn copy(m: &Mesh, at: DVec3) -> Object {
        let positions = m.positions.iter().map(|&p| (Vec3::from(p).as_dvec3() + at).as_vec3().to_array()).collect();
        Object::new("copy", Mesh { positions, ..m.clone() })
    }

    #[test]
    fn copies_moved_by_exact_steps_share_a_content_and_place_back_where_they_were() {
        let m = sphere();
        let first = translated(&copy(&m, DVec3::new(1.0, 2.0, 3.0))).expect("a mesh worth a use");
        for at in [DVec3::new(-40.25, 3.5, 17.0), DVec3::new(4000.5, -8.0, 250.0), DVec3::new(0.125, 0.25, -0.375)] {
            let o = copy(&m, at);
            let t = translated(&o).unwrap();
            assert_eq!(t.content, first.content, "a copy at {at}");
            // The first copy's mesh placed at this copy's corner is this copy, exactly.
            for (k, p) in first.positions.iter().enumerate() {
                assert_eq!(Vec3::from(*p).as_dvec3() + t.corner, o.world(o.mesh.positions[k]), "vertex {k} at {at}");
            }
        }
        // The same mesh placed by an anchor and a translation is a copy too.
        let placed =
            Object::placed("placed", m.clone(), DVec3::new(5.0e4, 0.0, 0.0), DAffine3::from_translation(DVec3::new(3.0, 4.0, 5.0)));
        assert_eq!(translated(&placed).unwrap().content, first.content);
        // Rounded far from the origin (an ulp of 2^-7 at 100,000, coarser than the mesh's
        // grid): another content.
        assert_ne!(translated(&copy(&m, DVec3::new(1.0e5, 0.0, 0.0))).unwrap().content, first.content);
    }

    #[test]
    fn a_copy_changed_scaled_or_turned_is_another_mesh() {
        let m = sphere();
        let content = |o: &Object| translated(o).unwrap().content;
        let first = content(&copy(&m, DVec3::ZERO));
        let mut moved = m.clone();
        moved.positions[5][1] += 0.01;
        let mut flipped = m.clone();
        flipped.indices.swap(0, 1);
        let scaled = Object::placed("scaled", m.clone(), DVec3::ZERO, DAffine3::from_scale(DVec3::splat(1.5)));
        let turned = Object::placed("turned", m.clone(), DVec3::ZERO, DAffine3::from_rotation_z(0.3));
        for (what, other) in [
            ("a vertex moved", content(&copy(&moved, DVec3::ZERO))),
            ("a triangle turned over", content(&copy(&flipped, DVec3::ZERO))),
            ("scaled", content(&scaled)),
            ("turned", content(&turned)),
        ] {
            assert_ne!(other, first, "{what}");
        }
    }

    #[test]
    fn small_meshes_are_not_worth_a_use() {
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        assert!(translated(&Object::new("box", m)).is_none());
    }
}
