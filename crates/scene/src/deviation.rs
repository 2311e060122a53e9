//! How far a simplified mesh lies from the surface it replaces, measured. meshoptimizer's
//! errors are quadric errors, distances to the input's planes: blind to what slides within a
//! plane. Edge collapse with its borders kept cannot open a flat surface, but vertex clustering
//! (the sloppy simplifier of HLODs and stand-ins) can drop a whole coplanar part, say one of a
//! race circuit's ground tiles, at an error of zero by its planes. What was there is then as
//! far from the result as the nearest surface left, which only a measurement finds.
//!
//! [`one_sided`] samples the input (its vertices, each triangle's centroid, and a barycentric
//! grid on long triangles) and finds each sample's nearest triangle of the result
//! through a uniform grid: the largest distance, approximately the one-sided Hausdorff
//! distance from input to result.

use crate::mesh::Mesh;
use glam::Vec3;

/// Cells of the grid over the result per triangle, about.
const CELLS_PER_TRIANGLE: f32 = 8.0;

/// Samples along an edge of a triangle of the input of a vertex clustering, at most: a long
/// thin triangle (a ground tile, a road strip) is sampled at about a sixteenth of the mesh's
/// extent, as a whole tile can go missing.
pub const CLUSTERING_STEPS: u32 = 16;

/// The largest distance from a sample of `from`'s surface to `to`'s, or `at_least` where that
/// is larger (a sample within it of some triangle is searched no further: most of an edge
/// collapse's samples lie within its quadric error of the result); infinite where `to` has no
/// triangle but `from` has. Samples: `from`'s vertices and centroids, and on a triangle longer
/// than `steps`-th of its extent a grid of that spacing (1: none; [`CLUSTERING_STEPS`]).
pub fn one_sided(from: &Mesh, to: &Mesh, at_least: f32, steps: u32) -> f32 {
    if from.indices.is_empty() {
        return at_least;
    }
    if to.indices.is_empty() {
        return f32::INFINITY;
    }
    let grid = Grid::new(to);
    let mut worst = at_least;
    samples(from, steps, |p| worst = worst.max(grid.nearest(p, worst)));
    worst
}

/// Calls `f` with points of `mesh`'s surface: each vertex a triangle uses, each triangle's
/// centroid, and on a triangle longer than a `most`-th of the mesh's extent a grid of about
/// that spacing along its longest and its shortest edge (a long sliver, as a pipe's side, gets
/// a row of points, not a square of them).
fn samples(mesh: &Mesh, most: u32, mut f: impl FnMut(Vec3)) {
    let mut used = vec![false; mesh.positions.len()];
    mesh.indices.iter().for_each(|&v| used[v as usize] = true);
    mesh.positions.iter().zip(&used).filter(|(_, u)| **u).for_each(|(p, _)| f(Vec3::from(*p)));
    let extent = bounds(&mesh.positions).map_or(0.0, |(lo, hi)| (hi - lo).max_element());
    let spacing = extent / most as f32;
    for t in mesh.indices.chunks_exact(3) {
        let v = [0, 1, 2].map(|k| Vec3::from(mesh.positions[t[k] as usize]));
        f((v[0] + v[1] + v[2]) / 3.0);
        // Edge k runs from corner k to corner k + 1; the corner the longest and the shortest
        // edges share spans the grid.
        let len = [0, 1, 2].map(|k| (v[(k + 1) % 3] - v[k]).length());
        let longest = (0..3).max_by(|&a, &b| len[a].total_cmp(&len[b])).unwrap_or(0);
        let shortest = (0..3).filter(|&k| k != longest).min_by(|&a, &b| len[a].total_cmp(&len[b])).unwrap_or(1);
        let steps = |l: f32| ((l / spacing.max(f32::MIN_POSITIVE)).ceil() as u32).clamp(1, most);
        let (su, sv) = (steps(len[longest]), steps(len[shortest]));
        if su == 1 && sv == 1 {
            continue;
        }
        // The shared corner, and the far ends of the two edges from it.
        let o = if (longest + 1) % 3 == shortest { (longest + 1) % 3 } else { longest };
        let far = |k: usize| if k == o { v[(k + 1) % 3] } else { v[k] };
        let (a, b) = (far(longest), far(shortest));
        for i in 0..=su {
            for j in 0..=sv {
                let (x, y) = (i as f32 / su as f32, j as f32 / sv as f32);
                if x + y <= 1.0 {
                    f(v[o] + (a - v[o]) * x + (b - v[o]) * y);
                }
            }
        }
    }
}

fn bounds(points: &[[f32; 3]]) -> Option<(Vec3, Vec3)> {
    let first = Vec3::from(*points.first()?);
    Some(points.iter().fold((first, first), |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p)))))
}

/// The triangles of a mesh binned by the cells their boxes overlap.
struct Grid {
    triangles: Vec<[Vec3; 3]>,
    lo: Vec3,
    hi: Vec3,
    cell: f32,
    dims: [i32; 3],
    /// Per cell, its range in `items`.
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    fn new(mesh: &Mesh) -> Grid {
        let triangles: Vec<[Vec3; 3]> =
            mesh.indices.chunks_exact(3).map(|t| [0, 1, 2].map(|k| Vec3::from(mesh.positions[t[k] as usize]))).collect();
        let (lo, hi) = bounds(&mesh.positions).expect("a mesh with triangles has positions");
        let size = (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
        // Cells about CELLS_PER_TRIANGLE per triangle over the box's non-flat axes.
        let cells = triangles.len() as f32 * CELLS_PER_TRIANGLE;
        let axes: Vec<f32> = size.to_array().into_iter().filter(|s| *s > size.max_element() * 1e-3).collect();
        let cell = (axes.iter().product::<f32>() / cells).powf(1.0 / axes.len() as f32).max(size.max_element() / 256.0);
        let dims = (size / cell).to_array().map(|d| (d.floor() as i32 + 1).clamp(1, 256));
        let mut grid = Grid { triangles, lo, hi, cell, dims, starts: Vec::new(), items: Vec::new() };
        // Counted first, then filled: each triangle in every cell its box overlaps.
        let count = (dims[0] * dims[1] * dims[2]) as usize;
        let mut starts = vec![0u32; count + 1];
        grid.each_cell(|cell, _| starts[cell + 1] += 1);
        for k in 0..count {
            starts[k + 1] += starts[k];
        }
        let mut items = vec![0u32; starts[count] as usize];
        let mut at = starts.clone();
        grid.each_cell(|cell, k| {
            items[at[cell] as usize] = k;
            at[cell] += 1;
        });
        (grid.starts, grid.items) = (starts, items);
        grid
    }

    /// Calls `f(cell, triangle)` for each cell each triangle's box overlaps.
    fn each_cell(&self, mut f: impl FnMut(usize, u32)) {
        for (k, t) in self.triangles.iter().enumerate() {
            let (a, b) = (self.index_of(t[0].min(t[1]).min(t[2])), self.index_of(t[0].max(t[1]).max(t[2])));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        f(self.flat([x, y, z]), k as u32);
                    }
                }
            }
        }
    }

    fn index_of(&self, p: Vec3) -> [i32; 3] {
        let c = ((p - self.lo) / self.cell).floor().to_array();
        [0, 1, 2].map(|k| (c[k] as i32).clamp(0, self.dims[k] - 1))
    }

    fn flat(&self, c: [i32; 3]) -> usize {
        ((c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]) as usize
    }

    /// The distance from `p` to the nearest triangle, searched in shells of cells around
    /// `p`'s until no nearer one can lie outside; a search stops early once the nearest found
    /// is within `enough` (its exact distance is then not needed).
    fn nearest(&self, p: Vec3, enough: f32) -> f32 {
        // A box is convex: nothing in it is nearer to p than to p clamped into it.
        let q = p.clamp(self.lo, self.hi);
        let outside = (p - q).length();
        let at = self.index_of(q);
        let mut best = f32::INFINITY;
        for r in 0.. {
            // The cells of the shell r cells out, clipped to the grid.
            let span = |k: usize| (at[k] - r).max(0)..=(at[k] + r).min(self.dims[k] - 1);
            for z in span(2) {
                for y in span(1) {
                    // Inside the shell's faces along z and y, only its two cells along x.
                    let side = (z - at[2]).abs() == r || (y - at[1]).abs() == r;
                    let step = if side || r == 0 { 1 } else { 2 * r as usize };
                    for x in (at[0] - r..=at[0] + r).step_by(step).filter(|x| (0..self.dims[0]).contains(x)) {
                        // A triangle's nearest point to p lies in one of the cells it is in: a
                        // cell farther than the best found holds no nearer one.
                        let lo = self.lo + Vec3::new(x as f32, y as f32, z as f32) * self.cell;
                        if (lo - p).max(p - lo - self.cell).max(Vec3::ZERO).length() >= best {
                            continue;
                        }
                        let cell = self.flat([x, y, z]);
                        for &k in &self.items[self.starts[cell] as usize..self.starts[cell + 1] as usize] {
                            best = best.min(distance(p, &self.triangles[k as usize]));
                            if best <= enough {
                                return best;
                            }
                        }
                    }
                }
            }
            // What is left lies past the faces of the cells searched that stop short of the
            // grid's: as far from q at least, and from p no nearer.
            let mut beyond = f32::INFINITY;
            for k in 0..3 {
                if at[k] - r > 0 {
                    beyond = beyond.min(q[k] - (self.lo[k] + (at[k] - r) as f32 * self.cell));
                }
                if at[k] + r < self.dims[k] - 1 {
                    beyond = beyond.min(self.lo[k] + (at[k] + r + 1) as f32 * self.cell - q[k]);
                }
            }
            if best <= beyond.max(outside) || beyond == f32::INFINITY {
                break;
            }
        }
        best
    }
}

/// The distance from `p` to triangle `t` (Ericson, Real-Time Collision Detection, sec. 5.1.5).
fn distance(p: Vec3, t: &[Vec3; 3]) -> f32 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (p - (a + ab * (d1 / (d1 - d3)))).length();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (p - (a + ac * (d2 / (d2 - d6)))).length();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).length();
    }
    let d = 1.0 / (va + vb + vc);
    let closest = a + ab * (vb * d) + ac * (vc * d);
    if closest.is_finite() { (p - closest).length() } else { ap.length().min(bp.length()).min(cp.length()) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes;

    fn quad_strip(tiles: u32, size: f32) -> Mesh {
        // Separate square tiles along x, each two triangles: ground as a game level lays it.
        let mut m = Mesh::default();
        for k in 0..tiles {
            let (x, n) = (k as f32 * size, m.positions.len() as u32);
            m.positions.extend([[x, 0.0, 0.0], [x + size, 0.0, 0.0], [x + size, 0.0, size], [x, 0.0, size]]);
            m.indices.extend([n, n + 2, n + 1, n, n + 3, n + 2]);
        }
        m
    }

    /// The same measure by brute force over every triangle, on the same samples.
    fn brute(from: &Mesh, to: &Mesh) -> f32 {
        let triangles: Vec<[Vec3; 3]> =
            to.indices.chunks_exact(3).map(|t| [0, 1, 2].map(|k| Vec3::from(to.positions[t[k] as usize]))).collect();
        let mut worst = 0.0f32;
        samples(from, CLUSTERING_STEPS, |p| worst = worst.max(triangles.iter().map(|t| distance(p, t)).fold(f32::INFINITY, f32::min)));
        worst
    }

    #[test]
    fn a_mesh_is_at_no_distance_from_itself() {
        let mut m = Mesh::default();
        shapes::lathe(&mut m, Vec3::ZERO, &shapes::sphere_profile(1.0, 16), 32);
        assert!(one_sided(&m, &m, 0.0, 1) < 1e-5);
        assert_eq!(one_sided(&m, &m, 0.5, 1), 0.5);
    }

    #[test]
    fn dropped_tiles_are_as_far_as_the_nearest_tile_left() {
        // Eight 10 m tiles in a row; the result keeps the first: the last tile's far edge is
        // 70 m away, which no plane of the input sees.
        let (all, first) = (quad_strip(8, 10.0), quad_strip(1, 10.0));
        let d = one_sided(&all, &first, 0.0, CLUSTERING_STEPS);
        assert!((d - 70.0).abs() < 1e-3, "{d}");
        assert!(one_sided(&first, &all, 0.0, CLUSTERING_STEPS) < 1e-5);
        assert_eq!(one_sided(&all, &first, 80.0, 1), 80.0);
        assert_eq!(one_sided(&all, &Mesh::default(), 0.0, 1), f32::INFINITY);
    }

    #[test]
    fn the_grid_finds_what_brute_force_finds() {
        // A sphere against the same sphere pruned and displaced, and against tiles around it.
        let mut rng = 12345u32;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 17;
            rng ^= rng << 5;
            rng as f32 / u32::MAX as f32
        };
        let mut sphere = Mesh::default();
        shapes::lathe(&mut sphere, Vec3::new(3.0, 1.0, -2.0), &shapes::sphere_profile(2.0, 12), 24);
        for _ in 0..4 {
            let mut to = Mesh { positions: sphere.positions.clone(), ..Mesh::default() };
            to.positions.iter_mut().for_each(|p| p[1] += next() * 0.2);
            to.indices = sphere.indices.chunks_exact(3).filter(|_| next() > 0.3).flatten().copied().collect();
            let tiles = quad_strip(3, 1.5 + next());
            for (from, to) in [(&sphere, &to), (&tiles, &to), (&to, &tiles)] {
                let (fast, slow) = (one_sided(from, to, 0.0, CLUSTERING_STEPS), brute(from, to));
                assert!((fast - slow).abs() <= 1e-4 * slow.max(1.0), "{fast} against {slow}");
            }
        }
    }
}
