//! Splits objects into chunks: a chunk is the unit of
//! culling and of LOD, so a long pipe or a city's ground plane is not drawn whole because one
//! end of it is visible. Two reasons to split: a chunk holds at most `max_triangles`, and a
//! chunk whose box is much larger than the boxes of its two halves (an elbowed pipe run, a
//! railing around a corner) is split in two, so that HC tests boxes that fit the geometry.

use crate::aabb::Aabb;
use crate::limits::LOOSE_MIN_TRIANGLES;
use crate::mesh::Mesh;
use glam::Vec3;

/// How to split.
#[derive(Clone, Copy, Debug)]
pub struct SplitOptions {
    /// Largest chunk, triangles (>= 1).
    pub max_triangles: u32,
    /// A chunk of at least twice [`LOOSE_MIN_TRIANGLES`] is split at its median when its
    /// halves' boxes have less than this fraction of its box's surface area (0: never).
    pub loose: f32,
}

/// Chunks of one mesh, and how many of the splits were for loose boxes.
pub struct Chunks {
    pub meshes: Vec<Mesh>,
    pub loose_splits: u32,
}

/// Splits `mesh` by recursive splits of triangle centroids along the longest axis of their
/// bounds. Every triangle lands in exactly one chunk; each chunk holds only the vertices it
/// uses (a mesh that is not split is returned as it is).
pub fn split(mesh: &Mesh, opts: SplitOptions) -> Chunks {
    let n = mesh.triangle_count();
    if n <= opts.max_triangles.max(1) as usize && !(opts.loose > 0.0 && n >= 2 * LOOSE_MIN_TRIANGLES as usize) {
        return Chunks { meshes: vec![mesh.clone()], loose_splits: 0 };
    }
    let tris = |t: &[u32]| [t[0], t[1], t[2]].map(|v| mesh.vertex(v));
    let centroids: Vec<Vec3> = mesh.indices.chunks_exact(3).map(|t| tris(t).into_iter().sum::<Vec3>() / 3.0).collect();
    let boxes: Vec<Aabb> = mesh.indices.chunks_exact(3).map(|t| tris(t).into_iter().fold(Aabb::EMPTY, Aabb::grow)).collect();
    let mut order: Vec<u32> = (0..centroids.len() as u32).collect();
    let mut parts: Vec<Vec<u32>> = Vec::new();
    let splitter = Splitter { centroids: &centroids, boxes: &boxes, max: opts.max_triangles.max(1) as usize, loose: opts.loose };
    let loose_splits = splitter.split(&mut order, &mut parts);
    let meshes = match parts.as_slice() {
        [_] => vec![mesh.clone()],
        _ => parts
            .iter()
            .map(|part| {
                let indices: Vec<u32> =
                    part.iter().flat_map(|&t| mesh.indices[t as usize * 3..t as usize * 3 + 3].iter().copied()).collect();
                mesh.sub_mesh(&indices)
            })
            .collect(),
    };
    Chunks { meshes, loose_splits }
}

struct Splitter<'a> {
    centroids: &'a [Vec3],
    boxes: &'a [Aabb],
    max: usize,
    loose: f32,
}

impl Splitter<'_> {
    /// Splits `tris` into `out`; returns the number of splits made for loose boxes.
    fn split(&self, tris: &mut [u32], out: &mut Vec<Vec<u32>>) -> u32 {
        let full = tris.len() > self.max;
        let may_be_loose = self.loose > 0.0 && tris.len() >= 2 * LOOSE_MIN_TRIANGLES as usize;
        if !full && !may_be_loose {
            return self.emit(tris, out);
        }
        let (lo, hi) = tris.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &t| {
            let c = self.centroids[t as usize];
            (lo.min(c), hi.max(c))
        });
        let axis = (hi - lo).max_position();
        // Over the limit: split so that the left part is a whole number of full chunks (fewer,
        // fuller chunks). Under it: halve, and keep the halves only if their boxes are tighter.
        let mid = if full { (tris.len().div_ceil(self.max) / 2) * self.max } else { tris.len() / 2 };
        tris.select_nth_unstable_by(mid, |&a, &b| self.centroids[a as usize][axis].total_cmp(&self.centroids[b as usize][axis]));
        let (left, right) = tris.split_at_mut(mid);
        let loose = !full && {
            let bound = |t: &[u32]| t.iter().fold(Aabb::EMPTY, |b, &t| b.union(self.boxes[t as usize]));
            let (l, r) = (bound(left), bound(right));
            l.half_area() + r.half_area() < self.loose * l.union(r).half_area()
        };
        if !full && !loose {
            return self.emit(tris, out);
        }
        loose as u32 + self.split(left, out) + self.split(right, out)
    }

    fn emit(&self, tris: &mut [u32], out: &mut Vec<Vec<u32>>) -> u32 {
        // Keep the input order inside a chunk: it is the generator's or the file's order,
        // which is usually coherent for the vertex cache.
        tris.sort_unstable();
        out.push(tris.to_vec());
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;

    #[test]
    fn every_triangle_lands_in_exactly_one_bounded_chunk() {
        let mut m = Mesh::default();
        shapes::grid_plane(&mut m, Vec3::ZERO, Vec3::new(100.0, 0.0, 30.0), 50, 15); // 1500 triangles
        // A plane's halves are no tighter than the plane: only the triangle limit splits it.
        let whole = split(&m, SplitOptions { max_triangles: 4096, loose: 0.7 });
        assert_eq!((whole.meshes.len(), whole.loose_splits), (1, 0));
        let chunks = split(&m, SplitOptions { max_triangles: 64, loose: 0.7 }).meshes;
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

    #[test]
    fn an_elbowed_pipe_is_split_where_its_box_is_loose() {
        // An L of two 20 m pipes, 0.2 m across: its box is 20 by 0.2 by 20, its legs' boxes thin.
        let mut m = Mesh::default();
        let l = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(20.0, 0.0, 0.0), Vec3::new(20.0, 0.0, 20.0)];
        shapes::tube(&mut m, &l, 0.1, 48, false);
        let whole = m.bounds().half_area();
        let n = m.triangle_count();
        let kept = split(&m, SplitOptions { max_triangles: 4096, loose: 0.0 });
        assert_eq!((kept.meshes.len(), kept.loose_splits), (1, 0));
        let c = split(&m, SplitOptions { max_triangles: 4096, loose: 0.7 });
        assert!(c.loose_splits >= 1 && c.meshes.len() == c.loose_splits as usize + 1);
        assert_eq!(c.meshes.iter().map(Mesh::triangle_count).sum::<usize>(), n);
        let parts: f32 = c.meshes.iter().map(|p| p.bounds().half_area()).sum();
        assert!(parts < 0.2 * whole, "parts' boxes {parts} against the L's {whole}");
        assert!(c.meshes.iter().all(|p| p.triangle_count() >= LOOSE_MIN_TRIANGLES as usize));
    }
}
