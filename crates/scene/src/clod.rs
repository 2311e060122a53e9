//! The cluster hierarchy of one object (Yoon 2003's view-dependent rendering as the field
//! builds it today: Nanite, zeux's `demo/clusterlod.h`, built by meshopt's `clod_build`).
//!
//! The object's triangles are grouped into clusters, clusters into groups; each group is
//! simplified with only the borders it shares with other groups locked, the result split into
//! new clusters, and those regrouped at the next level so that the old borders are simplified
//! too. A triangle of a simplified group carries two bounds ([`Cut`]): `lo`, the simplified
//! bounds of the group it was made from, and `hi`, those of its own group. A cut draws it while
//! `lo` meets tau and `hi` does not (`osw_scene::error_metric::LodView::takes`).
//!
//! A surface point is drawn exactly once by every cut when, along each chain of groups it
//! passes through, the projected error never decreases: then exactly one step of the chain
//! crosses tau. meshoptimizer builds a group's bounds as a sphere around its clusters' with the
//! largest error, which holds in exact arithmetic; here each group's sphere is made to enclose
//! the spheres of the groups its clusters were made from, and its error their largest, with a
//! margin for rounding (the projection grows with both).
//!
//! The original triangles leave in chunks of whole level-0 groups (the BVH's leaves); the
//! simplified clusters leave in pieces, which the build gives to BVH nodes (the build's owner stage).

use crate::aabb::Aabb;
use crate::format::{Cut, ErrorBound};
use crate::mesh::Mesh;
use glam::{DVec3, Vec3};

/// Triangles with where the cut draws each: triangle `t` at `cuts[cut_of[t]]`, or at
/// `cuts[0]` when `cut_of` is empty (static levels and small objects: no per-triangle array).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Piece {
    pub mesh: Mesh,
    pub cuts: Vec<Cut>,
    pub cut_of: Vec<u32>,
}

impl Piece {
    /// A mesh drawn at every tau (a static level, or an object too small for a hierarchy).
    pub fn always(mesh: Mesh) -> Piece {
        Piece { mesh, cuts: vec![Cut::ALWAYS], cut_of: Vec::new() }
    }

    /// The index in `cuts` of triangle `t`'s cut.
    pub fn cut(&self, t: usize) -> u32 {
        self.cut_of.get(t).copied().unwrap_or(0)
    }

    pub fn append(&mut self, o: &Piece) {
        let first = self.cuts.len() as u32;
        let mine: Vec<u32> = (0..self.mesh.triangle_count()).map(|t| self.cut(t)).collect();
        self.cut_of = mine;
        self.cut_of.extend((0..o.mesh.triangle_count()).map(|t| o.cut(t) + first));
        self.mesh.append(&o.mesh);
        self.cuts.extend_from_slice(&o.cuts);
    }

    /// The triangles never simplified further (the coarsest a cut draws), and the largest
    /// error they stand for.
    pub fn coarsest(&self) -> (Mesh, f32) {
        let (mut indices, mut error) = (Vec::new(), 0.0f32);
        for (k, t) in self.mesh.indices.chunks_exact(3).enumerate() {
            let cut = &self.cuts[self.cut(k) as usize];
            if cut.hi.error == f32::INFINITY {
                indices.extend_from_slice(t);
                error = error.max(cut.lo.error);
            }
        }
        (self.mesh.sub_mesh(&indices), error)
    }
}

/// An object's hierarchy: its original triangles in chunks, and its simplified groups.
#[derive(Debug, Default)]
pub struct Hierarchy {
    pub chunks: Vec<Piece>,
    /// The simplified clusters, in pieces of one chunk each, and that chunk (in `chunks`).
    pub coarse: Vec<Piece>,
    pub home: Vec<u32>,
    /// Simplified groups.
    pub groups: u64,
    /// Levels of simplification (0 when the object was too small for any).
    pub levels: u32,
    /// Triangles dropped from the simplified groups as fins ([`crate::fins`]).
    pub fins: u64,
}

/// A group as built: its bounds made monotone, its depth, and its clusters (triangles of the
/// object's vertices, each cluster with its cut), each made by simplifying the group
/// `refined` names (-1: the original triangles).
struct Group {
    bound: ErrorBound,
    depth: i32,
    clusters: Vec<(Vec<u32>, Cut)>,
    refined: Vec<i32>,
}

/// The groups a cut switches: triangles of one of clod_build's clusters (at most as many
/// vertices), and clusters a group aims at.
#[derive(Clone, Copy, Debug)]
struct GroupShape {
    cluster_triangles: usize,
    clusters: usize,
}

/// Groups of 16 clusters of 128 triangles (meshoptimizer's defaults: 32 triangles, 16
/// clusters): a faster build, a smaller file and less popping on the plant
/// (docs/measurements/2026-12-03-cluster-hierarchy.md).
const GROUPS: GroupShape = GroupShape { cluster_triangles: 128, clusters: 16 };

/// Groups of an object of at least [`LARGE_OBJECT`] triangles: 128 clusters of 256 (the most
/// triangles clod_build takes a cluster). Each group locks its border while it is simplified;
/// in an object that fills the view from near (paper 004's isosurface, 2.4M triangles) large
/// groups lock less of it and switch less of it as the eye moves: fewer triangles at the
/// same PSNR and much less popping. Larger groups fold more fans into fins
/// ([`crate::fins`]). On the plant's small objects they cost triangles at every PSNR.
/// docs/measurements/2026-12-05-cluster-hierarchy-large-groups.md, "Larger groups for a large object" and
/// "Fins dropped: groups of 128 clusters"
const LARGE_GROUPS: GroupShape = GroupShape { cluster_triangles: 256, clusters: 128 };

/// Triangles from which an object is built with [`LARGE_GROUPS`].
const LARGE_OBJECT: usize = 1 << 20;

/// Objects of at most this many triangles are one cluster already: drawn as they are.
const MIN_TRIANGLES: usize = crate::cluster::MAX_TRIANGLES;

/// The hierarchy of `mesh` (scene-local, cleaned), its original triangles in chunks of at most
/// `chunk_triangles` (whole groups; one group may exceed it).
pub fn build(mesh: &Mesh, chunk_triangles: u32) -> Hierarchy {
    build_with(mesh, chunk_triangles, if mesh.triangle_count() >= LARGE_OBJECT { LARGE_GROUPS } else { GROUPS })
}

/// [`build`] with groups of `shape`.
fn build_with(mesh: &Mesh, chunk_triangles: u32, shape: GroupShape) -> Hierarchy {
    let bounds = mesh.bounds();
    // The smallest error a simplified group reports: tau 0 draws the original everywhere.
    let min_error = (bounds.extent().length() * crate::limits::MIN_RELATIVE_ERROR).max(f32::MIN_POSITIVE);
    if mesh.triangle_count() <= MIN_TRIANGLES {
        let sphere = ErrorBound { center: bounds.center().into(), radius: bounds.extent().length() * 0.5 * (1.0 + 1e-5), error: 0.0 };
        let cut = Cut { hi: ErrorBound { error: f32::INFINITY, ..sphere }, lo: sphere };
        let n = mesh.triangle_count();
        return Hierarchy {
            chunks: vec![Piece { mesh: mesh.clone(), cuts: vec![cut], cut_of: vec![0; n] }],
            coarse: Vec::new(),
            home: Vec::new(),
            groups: 0,
            levels: 0,
            fins: 0,
        };
    }
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&mesh.positions), 12, 0).expect("12-byte vertices");
    // Each level aiming at 40% of the triangles of the one below (meshoptimizer's default:
    // half; measured with the group shape). Clusters are made again for drawing anyway
    // (crate::cluster), so the shape only sizes the groups a cut switches.
    let mut config = meshopt::clod_default_config(shape.cluster_triangles);
    config.partition_size = shape.clusters;
    config.simplify_ratio = 0.4;
    // Clusters by position alone: meshoptimizer's flexible clusterizer spent half the build.
    config.cluster_spatial = true;
    // No attributes are given, so permissive collapses across colour seams are not wanted.
    config.simplify_permissive = false;
    // A group's error: max(the largest error below, its step) + twice its step. At least the
    // triangle inequality's sum (below + step, as the static chains sum theirs), so a bound on
    // the distance to the original; the extra weight on the step spends a cut's triangles
    // where a step removed much for little error
    // (docs/measurements/2026-12-04-cluster-hierarchy-error.md, "The groups' error").
    config.simplify_error_merge_additive = 2.0;
    // The build clusters each block again its own way (crate::cluster): meshoptimizer's
    // reordering of each cluster for locality would be thrown away.
    config.optimize_clusters = false;
    let mut groups: Vec<Group> = Vec::new();
    meshopt::clod_build(config, &meshopt::ClodMesh::new(&mesh.indices, &adapter), |group, clusters| {
        let s = group.simplified;
        let mut own = ErrorBound {
            center: s.center,
            radius: s.radius,
            error: if s.error >= f32::MAX { f32::INFINITY } else { s.error.max(min_error) },
        };
        for c in clusters.iter().filter(|c| c.refined >= 0) {
            own = enclose(own, &groups[c.refined as usize].bound);
        }
        let lo = |refined: i32| if refined < 0 { ErrorBound { error: 0.0, ..own } } else { groups[refined as usize].bound };
        let refined = clusters.iter().map(|c| c.refined).collect();
        let clusters = clusters.iter().map(|c| (c.indices.to_vec(), Cut { hi: own, lo: lo(c.refined) })).collect();
        groups.push(Group { bound: own, depth: group.depth, clusters, refined });
        groups.len() as i32 - 1
    });
    let fins = drop_fins(&mut groups, &mesh.positions);
    let levels = groups.iter().map(|g| g.depth).max().unwrap_or(0) as u32;
    // A piece of clusters: their triangles out of the object's vertices, their cuts together.
    let piece = |members: &mut dyn Iterator<Item = &(Vec<u32>, Cut)>| {
        let (mut indices, mut cuts, mut cut_of) = (Vec::new(), Vec::<Cut>::new(), Vec::new());
        for (triangles, cut) in members {
            let k = cuts.iter().position(|x| x == cut).unwrap_or_else(|| {
                cuts.push(*cut);
                cuts.len() - 1
            });
            indices.extend_from_slice(triangles);
            cut_of.extend(std::iter::repeat_n(k as u32, triangles.len() / 3));
        }
        Piece { mesh: mesh.sub_mesh(&indices), cuts, cut_of }
    };
    let (original, coarse_groups): (Vec<&Group>, Vec<&Group>) = groups.iter().partition(|g| g.depth == 0);
    let boxes: Vec<(Aabb, usize)> = original
        .iter()
        .map(|g| (group_box(mesh, g.clusters.iter().flat_map(|c| &c.0)), g.clusters.iter().map(|c| c.0.len() / 3).sum()))
        .collect();
    let members = chunks(&boxes, chunk_triangles as usize);
    // The chunk each original vertex lies in (a vertex on a border: one of them).
    let mut home = vec![0u32; mesh.positions.len()];
    for (k, m) in members.iter().enumerate() {
        for (triangles, _) in m.iter().flat_map(|&g| &original[g].clusters) {
            triangles.iter().for_each(|&i| home[i as usize] = k as u32);
        }
    }
    let chunks = members.into_iter().map(|m| piece(&mut m.into_iter().flat_map(|k| &original[k].clusters))).collect();
    // A simplified cluster spans what it was made from, often several chunks, so no leaf's
    // box holds it whole. It leaves in pieces, one per chunk its triangles lie in (by their
    // first vertex), which the build gives to that chunk's leaf or the lowest node above it
    // whose box holds it (the build's owner stage): low in the BVH, where HC's box tests cull it.
    let (mut coarse, mut coarse_home) = (Vec::new(), Vec::new());
    for (triangles, cut) in coarse_groups.iter().flat_map(|g| &g.clusters) {
        let mut by_chunk: Vec<&[u32]> = triangles.chunks_exact(3).collect();
        by_chunk.sort_by_key(|t| home[t[0] as usize]);
        for part in by_chunk.chunk_by(|a, b| home[a[0] as usize] == home[b[0] as usize]) {
            coarse.push(piece(&mut std::iter::once(&(part.concat(), *cut))));
            coarse_home.push(home[part[0][0] as usize]);
        }
    }
    Hierarchy { chunks, coarse, home: coarse_home, groups: coarse_groups.len() as u64, levels, fins }
}

/// Drops the fins ([`crate::fins`]) from what each group's simplification made, and says how
/// many triangles went. In build order, so that the triangles a group was simplified from have
/// lost theirs already (a fin the next level keeps is no pair of its source).
fn drop_fins(groups: &mut [Group], positions: &[[f32; 3]]) -> u64 {
    let mut made: Vec<Vec<(usize, usize)>> = vec![Vec::new(); groups.len()];
    for (g, group) in groups.iter().enumerate() {
        for (k, &r) in group.refined.iter().enumerate().filter(|p| *p.1 >= 0) {
            made[r as usize].push((g, k));
        }
    }
    let triangles = |indices: &[u32]| indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect::<Vec<_>>();
    let mut dropped = 0;
    for (r, clusters) in made.iter().enumerate() {
        let all: Vec<[u32; 3]> = clusters.iter().flat_map(|&(g, k)| triangles(&groups[g].clusters[k].0)).collect();
        let source = || groups[r].clusters.iter().flat_map(|c| triangles(&c.0)).collect();
        let fins = crate::fins::fins(&all, source, positions, groups[r].bound.error);
        if fins.is_empty() {
            continue;
        }
        dropped += fins.len() as u64;
        let mut first = 0;
        for &(g, k) in clusters {
            let indices = &mut groups[g].clusters[k].0;
            let n = indices.len() / 3;
            let gone: Vec<usize> = fins.iter().filter(|&&i| (first..first + n).contains(&i)).map(|&i| i - first).collect();
            first += n;
            let kept = indices.chunks_exact(3).enumerate().filter(|(t, _)| !gone.contains(t));
            *indices = kept.flat_map(|p| p.1.iter().copied()).collect();
        }
    }
    dropped
}

/// `a` grown to enclose `b`'s sphere, with the larger error, rounded outwards (f32 centres and
/// radii, distances taken in f64 at run time).
fn enclose(a: ErrorBound, b: &ErrorBound) -> ErrorBound {
    let (ca, cb) = (DVec3::from(a.center.map(f64::from)), DVec3::from(b.center.map(f64::from)));
    let reach = (ca - cb).length() + b.radius as f64;
    let radius = (a.radius as f64).max(reach * (1.0 + 1e-5) + 1e-30);
    ErrorBound { center: a.center, radius: radius as f32, error: a.error.max(b.error) }
}

/// A sphere around every sphere of `bounds` (rounded outwards), with their errors folded by
/// `fold` (the largest for an upper bound, the smallest for a lower one). Zero for none.
pub fn enclosing(bounds: &[ErrorBound], fold: fn(f32, f32) -> f32) -> ErrorBound {
    let Some(first) = bounds.first() else { return bytemuck::Zeroable::zeroed() };
    let b = bounds.iter().fold(Aabb::EMPTY, |b, s| {
        let (c, r) = (Vec3::from(s.center), Vec3::splat(s.radius));
        b.union(Aabb::new(c - r, c + r))
    });
    let center = b.center();
    let seed = ErrorBound { center: center.into(), radius: 0.0, error: first.error };
    bounds.iter().fold(seed, |a, s| ErrorBound { error: fold(a.error, s.error), ..enclose(a, s) })
}

fn group_box<'a>(mesh: &Mesh, indices: impl Iterator<Item = &'a u32>) -> Aabb {
    Aabb::from_points(indices.map(|&i| &mesh.positions[i as usize]))
}

/// Groups (box, triangles) put together in chunks of at most `most` triangles by halving at
/// the median along the longest axis of their centres (a group larger than `most` alone).
fn chunks(groups: &[(Aabb, usize)], most: usize) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    let mut stack = vec![(0..groups.len()).collect::<Vec<usize>>()];
    while let Some(mut members) = stack.pop() {
        let triangles: usize = members.iter().map(|&k| groups[k].1).sum();
        if triangles <= most.max(1) || members.len() == 1 {
            out.push(members);
            continue;
        }
        let (lo, hi) = members.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &k| {
            let c = groups[k].0.center();
            (lo.min(c), hi.max(c))
        });
        let axis = (hi - lo).max_position();
        members.sort_unstable_by(|&a, &b| groups[a].0.center()[axis].total_cmp(&groups[b].0.center()[axis]));
        let (mut left, mut split) = (0, 0);
        while split < members.len() - 1 && (left + groups[members[split]].1) * 2 <= triangles {
            left += groups[members[split]].1;
            split += 1;
        }
        let right = members.split_off(split.max(1));
        stack.push(right);
        stack.push(members);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::ErrorBound;
    use crate::generators::shapes;

    fn sphere() -> Mesh {
        sphere_of(64)
    }

    /// A sphere of radius 10 in `rings` rings of twice `rings` segments.
    fn sphere_of(rings: u32) -> Mesh {
        let mut m = Mesh::default();
        shapes::lathe(&mut m, Vec3::ZERO, &shapes::sphere_profile(10.0, rings), 2 * rings);
        m.welded()
    }

    /// The pieces of `h` with every cut, flattened: (triangle's corner positions, cut).
    fn triangles(h: &Hierarchy) -> Vec<([[f32; 3]; 3], Cut)> {
        h.chunks
            .iter()
            .chain(&h.coarse)
            .flat_map(|p| {
                p.mesh
                    .indices
                    .chunks_exact(3)
                    .zip((0..).map(|t| p.cut(t)))
                    .map(|(t, c)| ([0, 1, 2].map(|k| p.mesh.positions[t[k] as usize]), p.cuts[c as usize]))
            })
            .collect()
    }

    #[test]
    fn the_original_triangles_are_in_the_chunks_and_every_chain_is_monotone() {
        let m = sphere();
        let h = build(&m, 1024);
        assert!(h.levels >= 3, "{} levels", h.levels);
        let original: usize = h.chunks.iter().map(|p| p.mesh.triangle_count()).sum();
        assert_eq!(original, m.triangle_count());
        assert!(h.chunks.iter().all(|p| p.cuts.iter().all(|c| c.lo.error == 0.0 && c.hi.error > 0.0)));
        // Chunks of whole groups (clod_build's groups are about 16 clusters of 128 triangles).
        assert!(h.chunks.len() >= m.triangle_count() / (GROUPS.clusters * GROUPS.cluster_triangles), "{} chunks", h.chunks.len());
        // Each lo bound is some group's hi bound, enclosed by it with an error no larger.
        let his: Vec<ErrorBound> = triangles(&h).iter().map(|t| t.1.hi).collect();
        for (_, cut) in triangles(&h).iter().filter(|t| t.1.lo.error > 0.0) {
            assert!(his.contains(&cut.lo));
            let d = (Vec3::from(cut.hi.center) - Vec3::from(cut.lo.center)).length();
            assert!(d + cut.lo.radius <= cut.hi.radius && cut.lo.error <= cut.hi.error, "{cut:?}");
        }
        assert!(his.iter().any(|b| b.error == f32::INFINITY), "the coarsest group is never simplified further");
    }

    #[test]
    fn a_simplified_triangle_lies_within_its_error_of_the_original() {
        // The sphere's triangles lie within `sag` of its radius 10 (the original's own chords);
        // a simplified triangle's points that lie further inside than that are at least that
        // much further from the original surface, which its `lo` error must bound.
        let m = sphere();
        let r = |p: Vec3| (p - Vec3::Y * 10.0).length();
        let sag = m
            .indices
            .chunks_exact(3)
            .map(|t| 10.0 - r(t.iter().map(|&i| Vec3::from(m.positions[i as usize])).sum::<Vec3>() / 3.0))
            .fold(0.0f32, f32::max);
        let mut checked = 0;
        for (t, cut) in triangles(&build(&m, 1024)).iter().filter(|t| t.1.lo.error > 0.0) {
            let [a, b, c] = t.map(Vec3::from);
            let inside = (0..=8)
                .flat_map(|i| (0..=8 - i).map(move |j| (i as f32 / 8.0, j as f32 / 8.0)))
                .map(|(u, v)| 10.0 - r(a + (b - a) * u + (c - a) * v))
                .fold(0.0f32, f32::max);
            assert!(inside - sag <= cut.lo.error, "a triangle {inside} inside the sphere (the original {sag}), its error {}", cut.lo.error);
            checked += 1;
        }
        assert!(checked > 1000, "{checked} simplified triangles");
    }

    /// The triangles `h`'s cut draws for `eye` and `tau`, after checking its edges: a hole or
    /// a crack leaves an edge drawn more often one way than the other; so does a fin, whose
    /// edges the surface uses too. With `once`, each directed edge (by position) must be drawn
    /// exactly once, which also finds a layer drawn twice; without, as often as its reverse
    /// (a part flattened into a two-sided ribbon draws its inner edges twice each way).
    fn checked_cut(h: &Hierarchy, eye: DVec3, tau: f64, once: bool) -> usize {
        let v = crate::error_metric::LodView { eye, focal_px: 1000.0, tau };
        let all = triangles(h);
        let drawn: Vec<_> = all.iter().filter(|t| v.takes(&t.1)).collect();
        let key = |p: [f32; 3]| p.map(f32::to_bits);
        let mut edges: std::collections::HashMap<_, i32> = std::collections::HashMap::new();
        for (t, _) in &drawn {
            for k in 0..3 {
                *edges.entry((key(t[k]), key(t[(k + 1) % 3]))).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            let back = edges.get(&(b, a)).copied();
            let want = if once { 1 } else { n };
            assert_eq!((n, back), (want, Some(want)), "eye {eye} tau {tau}: an edge drawn {n} times, its reverse {back:?}");
        }
        drawn.len()
    }

    #[test]
    fn every_cut_of_a_closed_surface_is_closed() {
        // At every tau and eye, with either group shape (an object's size picks one; the large
        // groups on a finer sphere, so that its cuts simplify too).
        for (m, shape) in [(sphere(), GROUPS), (sphere_of(128), LARGE_GROUPS)] {
            let h = build_with(&m, 1024, shape);
            for (eye, tau) in [
                (DVec3::new(0.0, 0.0, 12.0), 1.0),
                (DVec3::new(0.0, 0.0, 40.0), 4.0),
                (DVec3::splat(300.0), 8.0),
                (DVec3::new(11.0, 0.0, 0.0), 0.5),
                (DVec3::splat(1e5), 1.0),
            ] {
                let drawn = checked_cut(&h, eye, tau, true);
                // 2 units from the surface at tau 1 the first level's error still projects to
                // more than a pixel: only there may the cut be the original everywhere.
                let near = eye.length() < 20.0 && tau <= 1.0;
                assert!(drawn < m.triangle_count() || near, "eye {eye} tau {tau}: {drawn} triangles");
            }
            let far = checked_cut(&h, DVec3::splat(1e9), 1.0, true);
            assert!(far * 20 < m.triangle_count(), "far away the coarsest groups: {far} triangles");
        }
    }

    #[test]
    fn a_thin_pipe_has_no_hole_as_it_flattens() {
        // A capped pipe of radius 0.2 winding over 60 units, as the plant's are: its coarser
        // groups flatten it into two-sided ribbons (pairs on the same corners, which the fin
        // pass must tell from fins), its finer ones keep it round.
        let points: Vec<Vec3> = (0..300).map(|i| Vec3::new(i as f32 * 0.2, (i as f32 * 0.05).sin() * 3.0, 0.0)).collect();
        let mut m = Mesh::default();
        shapes::tube(&mut m, &points, 0.2, 12, true);
        let m = m.welded();
        let h = build(&m, 1024);
        assert!(h.levels >= 2, "{} levels", h.levels);
        let mut coarsest = usize::MAX;
        for (eye, tau) in [
            (DVec3::new(-0.5, 0.0, 0.0), 1.0),
            (DVec3::new(30.0, 0.0, 5.0), 1.0),
            (DVec3::new(30.0, 0.0, 5.0), 8.0),
            (DVec3::new(30.0, 40.0, 100.0), 2.0),
            (DVec3::splat(1e4), 1.0),
        ] {
            coarsest = coarsest.min(checked_cut(&h, eye, tau, false));
        }
        assert!(coarsest * 4 < m.triangle_count(), "the cuts never simplified: {coarsest} of {} triangles", m.triangle_count());
    }

    #[test]
    fn a_small_object_is_one_piece_drawn_at_every_tau() {
        let mut m = Mesh::default();
        shapes::add_box(&mut m, Vec3::ZERO, Vec3::ONE);
        let h = build(&m, 4096);
        assert_eq!((h.chunks.len(), h.coarse.len(), h.levels), (1, 0, 0));
        let v = crate::error_metric::LodView { eye: DVec3::splat(1e6), focal_px: 1000.0, tau: 100.0 };
        assert!(v.takes(&h.chunks[0].cuts[0]));
    }

    #[test]
    fn chunks_hold_whole_groups_within_the_limit() {
        let groups: Vec<(Aabb, usize)> =
            (0..40).map(|i| (Aabb::new(Vec3::splat(i as f32), Vec3::splat(i as f32 + 1.0)), 100 + i)).collect();
        let c = chunks(&groups, 1000);
        let mut all: Vec<usize> = c.iter().flatten().copied().collect();
        all.sort();
        assert_eq!(all, (0..40).collect::<Vec<_>>());
        assert!(c.iter().all(|m| m.iter().map(|&k| groups[k].1).sum::<usize>() <= 1000));
        assert!(c.len() <= 8, "{} chunks", c.len());
    }
}
