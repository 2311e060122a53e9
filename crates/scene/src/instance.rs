//! A mesh used several times, stored once: what one use of it looks like in the scene's frame.
//!
//! A use is an f64 affine transform (the input's placement, relative to the scene origin; see
//! [`crate::place`]). Its vertices are placed as `(linear · p + translation)` in f64 and
//! rounded to f32 once, as placing an expanded copy at the build would; a mirroring transform
//! also reverses each triangle's winding, so that a closed part stays wound outwards and its
//! back faces stay back faces. Cluster bounds follow the vertices; a cluster's normal cone
//! survives only a similarity (rotation, mirror, uniform scale), under which angles between
//! normals are kept. One function places a block both for the reader ([`crate::SceneFile`])
//! and for `--instances expand` at the build, so the two draw the same triangles.

use crate::aabb::Aabb;
use crate::block::{Encoded, Geometry, Indices, Layers, encode_with, geometry_of};
use crate::cluster::NO_CONE;
use crate::format::ClusterRecord;
use crate::mesh::Mesh;
use glam::{DAffine3, DVec3, Vec3};
use std::borrow::Cow;

/// How far a placement's linear part may be from a similarity (relative) and still keep the
/// normal cones: glTF stores rotations as f32 quaternions, which are unit only to about 1e-7.
const SIMILARITY_TOLERANCE: f64 = 1e-5;

/// One use's placement of a stored-once mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub affine: DAffine3,
    /// Reverses winding: the linear part mirrors.
    pub flips: bool,
    /// At least the largest factor by which the placement stretches a length: errors and radii
    /// in the mesh's frame times this bound them in the scene's.
    pub scale: f32,
    /// The linear part is a similarity (within [`SIMILARITY_TOLERANCE`]): cones are kept.
    pub similar: bool,
    /// The linear part maps axes onto axes (one non-zero per row and column: quarter turns,
    /// mirrors, scales): a box placed is exactly the box of its contents placed.
    pub axis_aligned: bool,
}

impl Placement {
    pub fn new(affine: DAffine3) -> Placement {
        let m = affine.matrix3;
        let gram = m.transpose() * m;
        // Largest singular value: at most the square root of the Gram matrix's largest absolute
        // row sum (exact for a similarity, where the Gram matrix is s^2 times the identity).
        let gram_rows = [gram.row(0), gram.row(1), gram.row(2)];
        let bound = gram_rows.iter().map(|r| r.abs().element_sum()).fold(0.0, f64::max).sqrt();
        let s2 = gram.x_axis.x.max(gram.y_axis.y).max(gram.z_axis.z);
        let off = (gram - glam::DMat3::from_diagonal(DVec3::splat(s2))).to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let rows = [m.row(0), m.row(1), m.row(2)];
        let one = |v: DVec3| v.to_array().iter().filter(|x| **x != 0.0).count() == 1;
        let axis_aligned = rows.iter().all(|r| one(*r)) && [m.x_axis, m.y_axis, m.z_axis].iter().all(|c| one(*c));
        Placement {
            affine,
            axis_aligned,
            flips: m.determinant() < 0.0,
            scale: (bound * (1.0 + 1e-6)) as f32,
            similar: s2 > 0.0 && off <= SIMILARITY_TOLERANCE * s2,
        }
    }

    pub fn point(&self, p: [f32; 3]) -> [f32; 3] {
        self.affine.transform_point3(Vec3::from_array(p).as_dvec3()).as_vec3().to_array()
    }

    pub fn points(&self, p: &[[f32; 3]]) -> Vec<[f32; 3]> {
        p.iter().map(|&p| self.point(p)).collect()
    }

    /// The box of `b`'s placed corners: encloses everything placed from inside `b`.
    pub fn bounds(&self, b: Aabb) -> Aabb {
        if b.is_empty() {
            return b;
        }
        let corner = |k: usize| {
            let c = [
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            ];
            self.point(c)
        };
        let placed: [[f32; 3]; 8] = std::array::from_fn(corner);
        let out = Aabb::from_points(&placed);
        if self.axis_aligned {
            // Each placed coordinate is one of the original's, scaled and moved, rounded alike.
            return out;
        }
        // Rounding to f32 may move a placed vertex by half an ulp past a placed corner.
        let pad = out.min.abs().max(out.max.abs()) * f32::EPSILON;
        Aabb::new(out.min - pad, out.max + pad)
    }

    /// `mesh` placed: positions placed, normals turned, winding reversed where the placement
    /// mirrors.
    pub fn mesh(&self, mesh: &Mesh) -> Mesh {
        let indices = if self.flips { flipped(&mesh.indices) } else { mesh.indices.clone() };
        let (colors, single_sided, texcoords) = (mesh.colors.clone(), mesh.single_sided.clone(), mesh.texcoords.clone());
        Mesh { positions: self.points(&mesh.positions), indices, colors, normals: self.normals(&mesh.normals), single_sided, texcoords }
    }

    fn normals(&self, normals: &[crate::normal::Normal]) -> Vec<crate::normal::Normal> {
        let mut out = normals.to_vec();
        crate::normal::transform(&mut out, self.affine.matrix3);
        out
    }

    /// A block placed: its own positions, normals and clusters, its indices reversed where the
    /// placement mirrors (else the stored ones), its colours the stored ones.
    pub fn geometry<'a>(&self, g: &Geometry<'a>) -> Geometry<'a> {
        let positions = self.points(&g.positions);
        let indices = match &g.indices {
            Indices::U16(ix) if self.flips => Indices::U16(Cow::Owned(flipped(ix))),
            Indices::U32(ix) if self.flips => Indices::U32(Cow::Owned(flipped(ix))),
            same => same.clone(),
        };
        let clusters = g.clusters.iter().map(|c| self.cluster(c, &positions, &g.indices)).collect();
        Geometry {
            positions: Cow::Owned(positions),
            colors: g.colors,
            normals: Cow::Owned(self.normals(&g.normals)),
            texcoords: g.texcoords,
            indices,
            clusters: Cow::Owned(clusters),
            cuts: g.cuts,
            occluders: g.occluders,
            opaque: g.opaque,
        }
    }

    fn cluster(&self, c: &ClusterRecord, positions: &[[f32; 3]], indices: &Indices) -> ClusterRecord {
        let range = c.first_index as usize..(c.first_index + c.index_count) as usize;
        let bbox = Aabb::from_points(range.map(|k| &positions[indices.get(k) as usize]));
        let center = self.point(c.center);
        let ulp = Vec3::from_array(center).abs().max_element() * f32::EPSILON * 4.0;
        let cone = c.cone_cutoff < NO_CONE && self.similar;
        let axis = (self.affine.matrix3 * Vec3::from_array(c.cone_axis).as_dvec3()).normalize_or_zero().as_vec3();
        let closed = match (c.single_sided(), cone) {
            (true, _) => Aabb::EMPTY,
            (false, true) => self.bounds(Aabb::new(c.closed_min.into(), c.closed_max.into())),
            (false, false) => Aabb::new(Vec3::ZERO, Vec3::ZERO),
        };
        ClusterRecord {
            center,
            radius: c.radius * self.scale + ulp,
            cone_apex: self.point(c.cone_apex),
            cone_axis: axis.to_array(),
            // Normals of a near-similarity turn by up to about its tolerance: a cutoff that
            // much stricter keeps the cone test conservative.
            cone_cutoff: if cone { (c.cone_cutoff + 10.0 * SIMILARITY_TOLERANCE as f32).min(NO_CONE) } else { NO_CONE },
            bbox_min: bbox.min.into(),
            bbox_max: bbox.max.into(),
            closed_min: closed.min.into(),
            closed_max: closed.max.into(),
            ..*c
        }
    }
}

fn flipped<T: Copy>(ix: &[T]) -> Vec<T> {
    let mut out = ix.to_vec();
    out.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
    out
}

/// A block as one use of its mesh places it: what a reader of the
/// block and its instance sees, stored as it is.
pub fn place_block(e: &Encoded, place: &Placement) -> Encoded {
    let g = place.geometry(&geometry_of(&e.bytes, &e.record));
    let indices: Vec<u32> = g.indices.iter().collect();
    // Sides are the clusters' (ClusterRecord::single_sided), passed on as they are.
    let mesh = Mesh {
        positions: g.positions.to_vec(),
        indices: indices.clone(),
        colors: g.colors.to_vec(),
        normals: g.normals.to_vec(),
        texcoords: g.texcoords.to_vec(),
        ..Mesh::default()
    };
    let layers = Layers { occluders: e.record.occluder_clusters(), opaque: e.record.opaque_clusters };
    encode_with(&mesh, &indices, &g.clusters, g.cuts, layers)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;

    fn placed_box(affine: DAffine3) -> (Mesh, Mesh) {
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        let p = Placement::new(affine);
        let placed = p.mesh(&m);
        (m, placed)
    }

    fn signed_volume(m: &Mesh) -> f64 {
        m.indices
            .chunks_exact(3)
            .map(|t| {
                let v = |i: u32| DVec3::from(m.positions[i as usize].map(f64::from));
                v(t[0]).dot(v(t[1]).cross(v(t[2]))) / 6.0
            })
            .sum()
    }

    #[test]
    fn a_mirror_keeps_a_closed_mesh_wound_outwards() {
        let mirror = DAffine3::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        let p = Placement::new(mirror);
        assert!(p.flips && p.similar && p.scale >= 1.0 && p.scale < 1.0001);
        let (m, placed) = placed_box(mirror);
        assert!(signed_volume(&m) > 0.0);
        assert!((signed_volume(&placed) - signed_volume(&m)).abs() < 1e-9, "{} vs {}", signed_volume(&placed), signed_volume(&m));
    }

    #[test]
    fn scale_bounds_every_stretch() {
        let shear =
            DAffine3 { matrix3: glam::DMat3::from_cols_array(&[1.0, 0.0, 0.0, 0.7, 1.0, 0.0, 0.0, 0.0, 2.0]), translation: DVec3::ZERO };
        let p = Placement::new(shear);
        assert!(!p.similar && !p.flips);
        for k in 0..200 {
            let d = DVec3::new((k as f64 * 0.37).sin(), (k as f64 * 1.3).cos(), (k as f64 * 0.11).sin()).normalize();
            assert!(shear.matrix3.mul_vec3(d).length() <= p.scale as f64, "{d}");
        }
        let turn = DAffine3::from_scale_rotation_translation(DVec3::splat(2.5), glam::DQuat::from_rotation_y(0.4), DVec3::X);
        let p = Placement::new(turn);
        assert!(p.similar && (p.scale - 2.5).abs() < 1e-5);
    }

    #[test]
    fn placed_bounds_enclose_the_placed_points() {
        let a = DAffine3::from_scale_rotation_translation(
            DVec3::new(0.3, 1.7, 2.0),
            glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.9),
            DVec3::new(1e5, -3.25, 7.0),
        );
        let (m, placed) = placed_box(a);
        let b = Placement::new(a).bounds(m.bounds());
        assert!(b.contains(&placed.bounds()), "{b:?} vs {:?}", placed.bounds());
    }
}
