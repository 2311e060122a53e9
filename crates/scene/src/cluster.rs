//! Clusters: each geometry block's triangles grouped into clusters of at most [`MAX_TRIANGLES`]
//! with a bounding sphere and a normal cone each (meshopt's), so that a pass can skip
//! the clusters outside the frustum or facing away from the eye inside the nodes it draws (as
//! niagara and Nanite do; the tests themselves are in `osw_cull::cluster`). The block's indices
//! are stored in cluster order, so a cluster is one range of them.
//!
//! Back faces: a back face is hidden behind a front face of the same surface only where that
//! surface is closed, wound outwards and the eye is outside it. Imported models are often open
//! or wound either way, and a chunk cut from a closed object is open where it was cut, so the
//! test is made on each connected part of the block (triangles joined by shared positions): a
//! part is closed when every directed edge has its reverse as often and its signed volume is
//! positive. A cluster keeps its cone when all its triangles lie in closed parts, with the
//! box of those parts, outside which the eye must be; CAD models are unions of small closed
//! parts (boxes, pipe runs, flanges). A part that the chunking cut open still hides its back
//! faces when its whole object is closed: then the object's box is the one to be outside of.
//!
//! Meshlets grown over a region of such a model mix every orientation and get cones wider than
//! a half-space, which cull nothing (measured on the 2M plant: 1% of clusters culled), so the
//! triangles are first binned by the axis their normal points along most.
//!
//! Within a bin, clusters are runs along the Morton curve of the triangles' centroids, cut at
//! MAX_TRIANGLES or MAX_VERTICES. meshopt's meshlet builder (greedy growth scored by
//! compactness and cone) made slightly tighter clusters (2M walk at tau 0, prev: 88,158
//! triangles a frame against 91,303; 19% against 17% of clusters outside the frustum, 22%
//! against 24% facing away) but took half of the whole build's time, twice the Morton runs', and
//! the billion-triangle build must run at 2M triangles a second.

use crate::aabb::Aabb;
use crate::format::{ClusterRecord, Cut};
use crate::mesh::{Layer, Mesh, layer};
use glam::{DVec3, Vec3};
use rustc_hash::FxHashMap;

/// Most triangles in a cluster. Measured with meshopt's meshlets on the 2M plant walk at tau 0
/// (prev, frustum and sphere-cone tests): clusters of 128 / 64 / 32 triangles leave 110,826 / 102,276 / 94,018 triangles a
/// frame of the PVS's 138,878 (smaller clusters are tighter for both tests; a pass tests 2.2K /
/// 3.6K / 6.6K clusters on the CPU, which costs little), the whole run 4% faster with 32 than
/// with 128; the 20M plant's file grows 10% (80 bytes a cluster) and its build 6%.
pub const MAX_TRIANGLES: usize = 32;

/// Most distinct vertices in a cluster: as many as triangles keeps clusters compact (and so
/// their spheres small) on meshes with shared vertices.
pub const MAX_VERTICES: usize = 32;

/// A cone cutoff that no eye passes (meshopt gives 1 for a cone wider than a half-space).
pub const NO_CONE: f32 = 2.0;

/// `mesh`'s indices in cluster order and the clusters (index range, sphere, cone, box of their
/// closed parts), those of the opaque triangles first, then the cut-outs', then the
/// translucent ones' (see [`Layer`]). Every triangle is kept exactly once, with its winding.
/// `object`: the box of the mesh's object when that object as a whole is closed and wound
/// outwards.
pub fn clusterize(mesh: &Mesh, object: Option<Aabb>) -> Clustered {
    clusterize_cut(mesh, object, &[Cut::ALWAYS], &[])
}

/// A block's triangles in clusters ([`clusterize_cut`]).
pub struct Clustered {
    /// The mesh's indices in cluster order.
    pub indices: Vec<u32>,
    pub clusters: Vec<ClusterRecord>,
    /// Where the cut draws each cluster.
    pub cuts: Vec<Cut>,
    /// Clusters `0..occluders` hold the opaque triangles, `occluders..opaque` the cut-outs.
    pub occluders: u32,
    pub opaque: u32,
}

/// [`clusterize`] for a part of a cluster hierarchy: triangle `t` is drawn where the cut takes
/// `cuts[cut_of[t]]` (`cut_of` empty: every triangle `cuts[0]`), and a cluster holds
/// triangles of one cut only.
pub fn clusterize_cut(mesh: &Mesh, object: Option<Aabb>, cuts: &[Cut], cut_of: &[u32]) -> Clustered {
    let block = Clustering {
        mesh,
        adapter: meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&mesh.positions), 12, 0).expect("12-byte positions"),
        parts: Parts::of(mesh),
        object,
        cuts,
    };
    let space = mesh.bounds();
    // Per triangle: by layer (opaque, cut-out, translucent), then by sides, then by cut, then
    // by facing bin, then along the Morton curve of its centroid. A cluster ends at a change of
    // the first four, at MAX_TRIANGLES triangles or at MAX_VERTICES vertices (which keeps it
    // compact where the curve jumps).
    let mut order: Vec<(u64, u32)> = mesh
        .indices
        .chunks_exact(3)
        .enumerate()
        .map(|(k, t)| {
            let layer = layer(&mesh.colors, t) as u64;
            let cut = cut_of.get(k).copied().unwrap_or(0) as u64;
            debug_assert!(cut <= CUT_MASK, "cut index {cut}");
            let centroid = t.iter().map(|&i| Vec3::from(mesh.positions[i as usize])).sum::<Vec3>() / 3.0;
            let single = mesh.is_single_sided(t) as u64;
            (layer << 62 | single << SINGLE_BIT | cut << 33 | (facing(mesh, t) as u64) << 30 | morton(&space, centroid) as u64, k as u32)
        })
        .collect();
    order.sort_unstable();
    let run = |key: u64| key >> 30;
    let mut indices = Vec::with_capacity(mesh.indices.len());
    let (mut clusters, mut cuts) = (Vec::new(), Vec::new());
    // Per vertex, the last cluster that used it: counts a cluster's distinct vertices.
    let mut stamp = vec![u32::MAX; mesh.positions.len()];
    let (mut occluders, mut opaque) = (0, 0);
    let (mut first_index, mut vertices) = (0u32, 0);
    for (n, &(key, k)) in order.iter().enumerate() {
        let t = &mesh.indices[k as usize * 3..k as usize * 3 + 3];
        let id = clusters.len() as u32;
        let new = t.iter().filter(|&&v| stamp[v as usize] != id).count();
        let triangles = (indices.len() - first_index as usize) / 3;
        if triangles == MAX_TRIANGLES || vertices + new > MAX_VERTICES || (n > 0 && run(order[n - 1].0) != run(key)) {
            let (c, cut) = block.cluster(&indices, first_index, order[n - 1].0);
            clusters.push(c);
            cuts.push(cut);
            first_index = indices.len() as u32;
            vertices = 0;
        }
        if key >> 62 == Layer::Opaque as u64 {
            occluders = clusters.len() as u32 + 1;
        }
        if key >> 62 <= Layer::CutOut as u64 {
            opaque = clusters.len() as u32 + 1;
        }
        let id = clusters.len() as u32;
        for &v in t {
            vertices += usize::from(stamp[v as usize] != id);
            stamp[v as usize] = id;
        }
        indices.extend_from_slice(t);
        if n + 1 == order.len() {
            let (c, cut) = block.cluster(&indices, first_index, key);
            clusters.push(c);
            cuts.push(cut);
        }
    }
    debug_assert_eq!(indices.len(), mesh.indices.len());
    Clustered { indices, clusters, cuts, occluders, opaque }
}

/// Bits of a cut's index in a triangle's sort key, and the bit above them that says it is
/// single-sided.
const CUT_MASK: u64 = 0x0fff_ffff;
const SINGLE_BIT: u64 = 61;

/// What each cluster of one block is made against: the mesh, its closed parts, the box of its
/// object when that is closed, and the cuts its triangles are drawn at.
struct Clustering<'a> {
    mesh: &'a Mesh,
    adapter: meshopt::VertexDataAdapter<'a>,
    parts: Parts,
    object: Option<Aabb>,
    cuts: &'a [Cut],
}

impl Clustering<'_> {
    /// The cluster of `indices[first_index..]`, whose triangles' sort key is `key`: its bounds
    /// and its cone (meshopt's) with the box of its closed parts or the object's when the
    /// triangles are opaque (back faces show through a translucent surface or a cut-out's
    /// holes), or an empty box when they are single-sided (never seen from behind, whatever
    /// the layer), and its cut.
    fn cluster(&self, indices: &[u32], first_index: u32, key: u64) -> (ClusterRecord, Cut) {
        let cluster = &indices[first_index as usize..];
        let b = meshopt::compute_cluster_bounds(cluster, &self.adapter);
        let cut = self.cuts[(key >> 33 & CUT_MASK) as usize];
        // A simplified triangle may have lost its object's closure; an original one has not.
        let closed = if key >> 62 == Layer::Opaque as u64 {
            self.parts.closed_box(cluster).or(self.object.filter(|_| cut.lo.error == 0.0))
        } else {
            None
        };
        let closed = if key >> SINGLE_BIT & 1 == 1 { Some(Aabb::EMPTY) } else { closed };
        let bbox = Aabb::from_points(cluster.iter().map(|&v| &self.mesh.positions[v as usize]));
        let c = ClusterRecord {
            center: b.center,
            radius: b.radius,
            cone_apex: b.cone_apex,
            cone_axis: b.cone_axis,
            cone_cutoff: if closed.is_some() { b.cone_cutoff } else { NO_CONE },
            first_index,
            index_count: cluster.len() as u32,
            bbox_min: bbox.min.into(),
            bbox_max: bbox.max.into(),
            closed_min: closed.map_or([0.0; 3], |c| c.min.into()),
            closed_max: closed.map_or([0.0; 3], |c| c.max.into()),
        };
        (c, cut)
    }
}

/// The 30-bit Morton code of `p` in `space` (10 bits an axis).
fn morton(space: &Aabb, p: Vec3) -> u32 {
    let q = ((p - space.min) / space.extent().max(Vec3::splat(f32::MIN_POSITIVE)) * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
    let spread = |v: f32| {
        let mut x = v as u32;
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        (x | (x << 2)) & 0x0924_9249
    };
    spread(q.x) | (spread(q.y) << 1) | (spread(q.z) << 2)
}

/// The bin of a triangle by the axis and sign its normal points along most (+x, -x, +y, -y,
/// +z, -z: 0 to 5), 6 without a normal. Within one bin a meshlet's normals stay within about
/// 55 degrees of the axis.
fn facing(mesh: &Mesh, t: &[u32]) -> u32 {
    let n = normal(mesh, t);
    let a = n.abs();
    if n == DVec3::ZERO {
        6
    } else if a.x >= a.y && a.x >= a.z {
        u32::from(n.x < 0.0)
    } else if a.y >= a.z {
        2 + u32::from(n.y < 0.0)
    } else {
        4 + u32::from(n.z < 0.0)
    }
}

fn point(mesh: &Mesh, i: u32) -> DVec3 {
    DVec3::from(mesh.positions[i as usize].map(f64::from))
}

fn normal(mesh: &Mesh, t: &[u32]) -> DVec3 {
    let (a, b, c) = (point(mesh, t[0]), point(mesh, t[1]), point(mesh, t[2]));
    (b - a).cross(c - a)
}

/// The connected parts of a mesh's opaque triangles (joined by a shared position), which of
/// them are closed and wound outwards, and their boxes. Translucent triangles close nothing: a
/// back face behind one is seen through it.
pub struct Parts {
    /// Per vertex, its part.
    part_of: Vec<u32>,
    /// Per part (indexed by its name, see `of`): its box, or None when it is open.
    closed: Vec<Option<Aabb>>,
    /// Whether every part with a triangle is closed.
    all_closed: bool,
}

impl Parts {
    pub fn of(mesh: &Mesh) -> Parts {
        // Weld equal positions: a generated or exported mesh repeats a position where normals
        // or colours differ.
        let mut weld: FxHashMap<[u32; 3], u32> = FxHashMap::default();
        weld.reserve(mesh.positions.len());
        let welded: Vec<u32> = mesh
            .positions
            .iter()
            .map(|p| {
                let n = weld.len() as u32;
                *weld.entry(p.map(f32::to_bits)).or_insert(n)
            })
            .collect();
        let opaque = || mesh.indices.chunks_exact(3).filter(|t| layer(&mesh.colors, t) == Layer::Opaque);
        let mut uf = UnionFind::new(weld.len());
        for t in opaque() {
            uf.join(welded[t[0] as usize], welded[t[1] as usize]);
            uf.join(welded[t[0] as usize], welded[t[2] as usize]);
        }
        // A part is named by its union-find root (a welded id).
        let part_of: Vec<u32> = welded.iter().map(|&w| uf.find(w)).collect();
        let parts = weld.len();
        // +1 for a -> b and -1 for b -> a on the edge's sorted key; a part is closed when all
        // its edges sum to 0 (and it has a triangle), outward when its signed volume is > 0.
        let mut edges: FxHashMap<(u32, u32), i32> = FxHashMap::default();
        edges.reserve(mesh.indices.len());
        let mut volume = vec![0.0f64; parts];
        let mut has_triangle = vec![false; parts];
        let mut boxes = vec![Aabb::EMPTY; parts];
        for t in opaque() {
            let v = [t[0], t[1], t[2]].map(|i| welded[i as usize]);
            for k in 0..3 {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                if a != b {
                    *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
                }
            }
            let part = part_of[t[0] as usize] as usize;
            let (a, b, c) = (point(mesh, t[0]), point(mesh, t[1]), point(mesh, t[2]));
            volume[part] += a.dot(b.cross(c));
            has_triangle[part] = true;
            for &i in t {
                boxes[part] = boxes[part].grow(Vec3::from(mesh.positions[i as usize]));
            }
        }
        let mut open: Vec<bool> = (0..parts).map(|p| !(has_triangle[p] && volume[p] > 0.0)).collect();
        for (&(a, _), &c) in &edges {
            if c != 0 {
                open[uf.find(a) as usize] = true;
            }
        }
        let all_closed = (0..parts).all(|p| !has_triangle[p] || !open[p]);
        let closed = boxes.into_iter().zip(open).map(|(b, open)| (!open).then_some(b)).collect();
        Parts { part_of, closed, all_closed }
    }

    /// The box of the parts of the triangles `indices` when every one is closed.
    pub fn closed_box(&self, indices: &[u32]) -> Option<Aabb> {
        indices.iter().try_fold(Aabb::EMPTY, |b, &i| Some(b.union(self.closed[self.part_of[i as usize] as usize]?)))
    }

    /// Whether the whole mesh is closed and wound outwards: every part is.
    pub fn all_closed(&self) -> bool {
        self.all_closed
    }
}

struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    fn new(n: usize) -> UnionFind {
        UnionFind { parent: (0..n as u32).collect() }
    }

    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let up = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = up;
            x = up;
        }
        x
    }

    fn join(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.parent[a.max(b) as usize] = a.min(b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generators::shapes::{add_box, grid_plane};

    fn sorted_triangles(m: &Mesh) -> Vec<[u32; 3]> {
        let mut t: Vec<[u32; 3]> = m
            .indices
            .chunks_exact(3)
            .map(|t| {
                // Rotate so the smallest index leads (the winding is kept).
                let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            })
            .collect();
        t.sort_unstable();
        t
    }

    #[test]
    fn boxes_are_closed_parts_a_plane_an_open_and_an_inverted_box_are_not() {
        let mut m = Mesh::default();
        add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        add_box(&mut m, Vec3::splat(3.0), Vec3::splat(4.0));
        let parts = Parts::of(&m);
        assert!(parts.all_closed());
        assert_eq!(parts.closed_box(&m.indices[..3]), Some(Aabb::new(Vec3::ZERO, Vec3::ONE)), "one part's box");
        let mut inverted = m.clone();
        for t in inverted.indices[..36].chunks_exact_mut(3) {
            t.swap(1, 2);
        }
        let parts = Parts::of(&inverted);
        assert!(parts.closed_box(&inverted.indices[..3]).is_none(), "wound inwards");
        assert!(parts.closed_box(&inverted.indices[36..]).is_some(), "the other box is still closed");
        let mut open = m.clone();
        open.indices.drain(30..36);
        assert!(!Parts::of(&open).all_closed(), "a face missing");
        let mut plane = Mesh::default();
        grid_plane(&mut plane, Vec3::ZERO, Vec3::ONE, 4, 4);
        assert!(!Parts::of(&plane).all_closed());
    }

    #[test]
    fn clusters_cover_every_triangle_once_and_bound_their_vertices() {
        let mut m = Mesh::default();
        for i in 0..200 {
            let o = Vec3::new(i as f32 * 1.5, (i % 7) as f32, 0.0);
            add_box(&mut m, o, o + Vec3::ONE);
        }
        let before = sorted_triangles(&m);
        let c = clusterize(&m, None);
        let clusters = c.clusters;
        m.indices = c.indices;
        assert_eq!((c.occluders as usize, c.opaque as usize), (clusters.len(), clusters.len()), "no colours: every triangle opaque");
        assert_eq!(sorted_triangles(&m), before);
        let mut next = 0;
        for c in &clusters {
            assert_eq!(c.first_index, next);
            assert!(c.index_count > 0 && c.index_count as usize <= MAX_TRIANGLES * 3);
            next += c.index_count;
            let center = Vec3::from(c.center);
            let closed = Aabb::new(c.closed_min.into(), c.closed_max.into());
            for &i in &m.indices[c.first_index as usize..(c.first_index + c.index_count) as usize] {
                let p = Vec3::from(m.positions[i as usize]);
                assert!(p.distance(center) <= c.radius * 1.0001 + 1e-6);
                assert!(p.cmpge(c.aabb().min).all() && p.cmple(c.aabb().max).all());
                assert!(p.cmpge(closed.min).all() && p.cmple(closed.max).all());
            }
            assert!(c.cone_cutoff < NO_CONE, "boxes are closed and one-facing clusters have a cone");
        }
        assert_eq!(next as usize, m.indices.len());
    }

    #[test]
    fn an_open_mesh_keeps_no_cone() {
        let mut m = Mesh::default();
        grid_plane(&mut m, Vec3::ZERO, Vec3::ONE, 20, 20);
        let clusters = clusterize(&m, None).clusters;
        assert!(!clusters.is_empty());
        assert!(clusters.iter().all(|c| c.cone_cutoff == NO_CONE));
    }

    #[test]
    fn cut_outs_come_between_the_opaque_and_the_translucent_without_a_cone_and_close_nothing() {
        // Three closed boxes; the second's front face is a cut-out, the third's glass.
        let mut m = Mesh::default();
        for x in [0.0, 3.0, 6.0] {
            add_box(&mut m, Vec3::X * x, Vec3::new(x + 1.0, 1.0, 1.0));
        }
        m.paint([200, 200, 200, 255]);
        let front_of = |m: &Mesh, x: f32| -> Vec<u32> {
            let on_front = |t: &&[u32]| t.iter().all(|&v| m.positions[v as usize][2] == 1.0 && m.positions[v as usize][0] >= x);
            m.indices.chunks_exact(3).filter(on_front).flatten().copied().collect()
        };
        let (cut_out, glass) =
            (front_of(&m, 3.0).into_iter().filter(|&v| m.positions[v as usize][0] < 5.0).collect::<Vec<_>>(), front_of(&m, 6.0));
        cut_out.iter().for_each(|&v| m.colors[v as usize][3] = crate::mesh::CUT_OUT);
        glass.iter().for_each(|&v| m.colors[v as usize][3] = crate::mesh::alpha(0.2));
        assert!(m.cut_out_triangles() >= 2 && m.translucent_triangles() >= 2);
        let c = clusterize(&m, None);
        let (occluders, opaque) = (c.occluders as usize, c.opaque as usize);
        assert!(0 < occluders && occluders < opaque && opaque < c.clusters.len(), "{occluders} {opaque} {}", c.clusters.len());
        let tris = |r: &ClusterRecord| {
            c.indices[r.first_index as usize..(r.first_index + r.index_count) as usize].chunks_exact(3).collect::<Vec<_>>()
        };
        for (k, r) in c.clusters.iter().enumerate() {
            let want = if k < occluders {
                Layer::Opaque
            } else if k < opaque {
                Layer::CutOut
            } else {
                Layer::Translucent
            };
            assert!(tris(r).iter().all(|t| layer(&m.colors, t) == want), "cluster {k}");
        }
        assert!(c.clusters[occluders..].iter().all(|r| r.cone_cutoff == NO_CONE));
        // The boxes with a cut-out or glass face are open: their back faces show through.
        let in_box =
            |r: &ClusterRecord, x: f32| tris(r).iter().flat_map(|t| t.iter()).all(|&v| (x..=x + 1.0).contains(&m.positions[v as usize][0]));
        assert!(c.clusters[..occluders].iter().filter(|r| in_box(r, 3.0)).all(|r| r.cone_cutoff == NO_CONE));
        assert!(
            c.clusters[..occluders].iter().filter(|r| in_box(r, 0.0)).all(|r| r.cone_cutoff < NO_CONE),
            "the closed box keeps its cones"
        );
    }

    #[test]
    fn translucent_triangles_come_last_without_a_cone_and_close_nothing() {
        // Two closed boxes; the second's front face (z = 1, two triangles) is glass.
        let mut m = Mesh::default();
        add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        add_box(&mut m, Vec3::X * 3.0, Vec3::new(4.0, 1.0, 1.0));
        m.paint([200, 200, 200, 255]);
        let all_opaque = clusterize(&m, None).clusters;
        assert!(all_opaque.iter().all(|c| c.cone_cutoff < NO_CONE), "both boxes closed: every cluster keeps its cone");
        let front: Vec<u32> =
            m.indices[36..].chunks_exact(3).filter(|t| t.iter().all(|&v| m.positions[v as usize][2] == 1.0)).flatten().copied().collect();
        assert_eq!(front.len(), 6);
        for &v in &front {
            m.colors[v as usize][3] = crate::mesh::alpha(0.2);
        }
        let translucent = m.translucent_triangles();
        let crate::cluster::Clustered { indices, clusters, opaque, .. } = clusterize(&m, None);
        let opaque = opaque as usize;
        assert!(opaque > 0 && opaque < clusters.len());
        let tris = |c: &ClusterRecord| {
            indices[c.first_index as usize..(c.first_index + c.index_count) as usize].chunks_exact(3).collect::<Vec<_>>()
        };
        for (k, c) in clusters.iter().enumerate() {
            let glass = tris(c).iter().filter(|t| crate::mesh::is_translucent(&m.colors, t)).count();
            assert_eq!(glass, if k < opaque { 0 } else { tris(c).len() }, "cluster {k}");
        }
        let back: u32 = clusters[opaque..].iter().map(|c| c.index_count / 3).sum();
        assert_eq!(back as usize, translucent);
        assert!(clusters[opaque..].iter().all(|c| c.cone_cutoff == NO_CONE));
        // The glass box is open once its glass is taken out: its back faces show through.
        let of_glass_box = |c: &&ClusterRecord| tris(c).iter().flat_map(|t| t.iter()).any(|&v| m.positions[v as usize][0] >= 3.0);
        assert!(clusters[..opaque].iter().filter(of_glass_box).all(|c| c.cone_cutoff == NO_CONE));
    }
}
