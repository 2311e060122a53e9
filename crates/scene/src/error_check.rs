//! The stored errors of a scene's coarser levels checked against the geometry they stand for:
//! each LOD and HLOD's distance from the full detail of its BVH node (the finest level of every
//! leaf under it), measured by brute force over the level's triangles from points of the full
//! detail (its vertices, edge midpoints and centroids, evenly thinned to at most
//! [`MOST_POINTS`]). The build measures each simplification step against its input through a
//! grid ([`crate::deviation`]); this measures from the original, another way, so that a level
//! whose error understates what it dropped shows here.

use crate::file::{SceneError, SceneFile};
use glam::Vec3;

/// Points of a node's full detail measured, at most.
pub const MOST_POINTS: usize = 600;

/// One coarser level measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    /// The BVH node and its LOD node.
    pub node: u32,
    pub lod: u32,
    /// The level's stored error and the largest distance measured (world units).
    pub error: f32,
    pub distance: f32,
}

impl Measured {
    /// How many times its stored error the level lies from its full detail.
    pub fn ratio(&self) -> f32 {
        self.distance / self.error.max(f32::MIN_POSITIVE)
    }
}

/// Every coarser level of `scene` (a leaf's levels after its first, a group's HLOD), measured.
pub fn measure(scene: &SceneFile) -> Result<Vec<Measured>, SceneError> {
    let mut out = Vec::new();
    for node in 0..scene.bvh_count() {
        let r = *scene.node(node);
        let finest = usize::from(r.child_count == 0);
        if r.lod_count as usize <= finest {
            continue;
        }
        let points = full_detail_points(scene, node)?;
        if points.is_empty() {
            continue;
        }
        for lod in r.lods().skip(finest) {
            let triangles = triangles(scene, lod)?;
            let distance = points.iter().map(|p| nearest(*p, &triangles)).fold(0.0, f32::max);
            out.push(Measured { node, lod, error: scene.node(lod).error, distance });
        }
    }
    Ok(out)
}

fn triangles(scene: &SceneFile, lod: u32) -> Result<Vec<[Vec3; 3]>, SceneError> {
    let g = scene.geometry(lod)?;
    Ok((0..g.indices.len() / 3).map(|t| [0, 1, 2].map(|k| Vec3::from(g.positions[g.indices.get(3 * t + k) as usize]))).collect())
}

/// Points of the finest level of every leaf under `node`, evenly thinned to MOST_POINTS.
fn full_detail_points(scene: &SceneFile, node: u32) -> Result<Vec<Vec3>, SceneError> {
    let (mut leaves, mut stack) = (Vec::new(), vec![node]);
    while let Some(n) = stack.pop() {
        let r = scene.node(n);
        if r.child_count == 0 {
            leaves.push(r.first_lod);
        } else {
            stack.extend(r.children());
        }
    }
    let mut points = Vec::new();
    for lod in leaves {
        for [a, b, c] in triangles(scene, lod)? {
            points.extend([a, (a + b) / 2.0, (a + b + c) / 3.0]);
        }
    }
    let step = points.len().div_ceil(MOST_POINTS).max(1);
    Ok(points.into_iter().step_by(step).collect())
}

fn nearest(p: Vec3, triangles: &[[Vec3; 3]]) -> f32 {
    triangles.iter().map(|t| distance(p, t)).fold(f32::INFINITY, f32::min)
}

/// The distance from `p` to triangle `t`: to its plane where `p` projects inside it, else to
/// the nearest of its edges (written apart from crate::deviation's, to check it).
fn distance(p: Vec3, t: &[Vec3; 3]) -> f32 {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let inside = n.length_squared() > 0.0 && (0..3).all(|k| (t[(k + 1) % 3] - t[k]).cross(p - t[k]).dot(n) >= 0.0);
    if inside {
        return (p - t[0]).dot(n.normalize()).abs();
    }
    (0..3).map(|k| segment(p, t[k], t[(k + 1) % 3])).fold(f32::INFINITY, f32::min)
}

fn segment(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let s = if ab.length_squared() > 0.0 { ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * s)).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_to_a_triangle_inside_and_past_its_edges_and_corners() {
        let t = [Vec3::ZERO, Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 4.0)];
        assert_eq!(distance(Vec3::new(1.0, 2.0, 1.0), &t), 2.0);
        assert_eq!(distance(Vec3::new(-3.0, 0.0, 1.0), &t), 3.0);
        assert_eq!(distance(Vec3::new(-3.0, 4.0, -1.0), &t), (9.0f32 + 16.0 + 1.0).sqrt());
        assert!((distance(Vec3::new(3.0, 0.0, 3.0), &t) - 2.0f32.sqrt()).abs() < 1e-6);
        // A degenerate triangle is its edges.
        let flat = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert_eq!(distance(Vec3::new(1.0, 1.0, 0.0), &flat), 1.0);
    }
}
