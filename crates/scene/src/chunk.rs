//! Splits large objects into chunks of bounded triangle count (GigaWalk style, paper 002 sec. 4):
//! a chunk is the unit of culling and of LOD, so a long pipe or a city's ground plane is not
//! drawn whole because one end of it is visible.

use crate::mesh::{Mesh, sub_mesh};
use glam::Vec3;

/// Splits `mesh` into chunks of at most `max_triangles` triangles by recursive median splits
/// of triangle centroids along the longest axis of their bounds. Every triangle lands in
/// exactly one chunk; each chunk holds only the vertices it uses. `max_triangles >= 1`.
pub fn split(mesh: &Mesh, max_triangles: u32) -> Vec<Mesh> {
    let max = max_triangles.max(1) as usize;
    if mesh.triangle_count() <= max {
        return vec![mesh.clone()];
    }
    let centroids: Vec<Vec3> =
        mesh.indices.chunks_exact(3).map(|t| (mesh.vertex(t[0]) + mesh.vertex(t[1]) + mesh.vertex(t[2])) / 3.0).collect();
    let mut tris: Vec<u32> = (0..centroids.len() as u32).collect();
    let mut out = Vec::new();
    split_range(&mut tris, &centroids, max, &mut |part| {
        let indices: Vec<u32> = part.iter().flat_map(|&t| mesh.indices[t as usize * 3..t as usize * 3 + 3].iter().copied()).collect();
        out.push(sub_mesh(&mesh.positions, &indices));
    });
    out
}

fn split_range(tris: &mut [u32], centroids: &[Vec3], max: usize, emit: &mut impl FnMut(&[u32])) {
    if tris.len() <= max {
        // Keep the input order inside a chunk: it is the generator's or the file's order,
        // which is usually coherent for the vertex cache.
        tris.sort_unstable();
        emit(tris);
        return;
    }
    let (lo, hi) = tris.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &t| {
        let c = centroids[t as usize];
        (lo.min(c), hi.max(c))
    });
    let axis = (hi - lo).max_position();
    // Split so that the left part is a whole number of full chunks: fewer, fuller chunks.
    let chunks = tris.len().div_ceil(max);
    let mid = (chunks / 2) * max;
    tris.select_nth_unstable_by(mid, |&a, &b| centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis]));
    let (left, right) = tris.split_at_mut(mid);
    split_range(left, centroids, max, emit);
    split_range(right, centroids, max, emit);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;

    #[test]
    fn every_triangle_lands_in_exactly_one_bounded_chunk() {
        let mut m = Mesh::default();
        shapes::grid_plane(&mut m, Vec3::ZERO, Vec3::new(100.0, 0.0, 30.0), 50, 15); // 1500 triangles
        let chunks = split(&m, 64);
        assert!(chunks.iter().all(|c| c.triangle_count() <= 64 && c.triangle_count() > 0));
        assert_eq!(chunks.iter().map(Mesh::triangle_count).sum::<usize>(), 1500);
        assert_eq!(chunks.len(), 1500usize.div_ceil(64));
        let key = |m: &Mesh| -> Vec<[u32; 3]> {
            m.indices
                .chunks_exact(3)
                .map(|t| {
                    [0, 1, 2]
                        .map(|k| m.positions[t[k] as usize].map(f32::to_bits))
                        .map(|p| p[0] ^ p[1].rotate_left(11) ^ p[2].rotate_left(22))
                })
                .collect()
        };
        let mut all: Vec<[u32; 3]> = chunks.iter().flat_map(key).collect();
        let mut orig = key(&m);
        all.sort();
        orig.sort();
        assert_eq!(all, orig);
    }
}
