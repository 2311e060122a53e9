//! Where a cluster hierarchy's simplified clusters go in the BVH: each piece of one (what of
//! it lies in one chunk, see [`crate::clod`]) to its chunk's leaf or the lowest node above it
//! whose box holds it, so that V(i) stays a set of node ids and a node's box bounds everything
//! it draws (HC's occlusion tests stay conservative). A piece's vertices are vertices of its
//! object's original triangles, so the object's lowest common ancestor holds it.
//!
//! Up from the chunk, not down from the ancestor: boxes overlap, and the first child found to
//! hold a piece is often a node whose box holds it only by spanning empty space (a wall along
//! the whole site beside a block of bays), below which no box does.
//!
//! A node's HLOD stands for its whole subtree, so it may only be built where no object under
//! the node reaches outside it: otherwise a coarse cluster of that object, owned above, and the
//! HLOD could both be drawn over the same surface, or a cluster owned below, which the HLOD
//! does not hold, not at all.

use super::stream::Chunked;
use crate::bvh::BvhNode;

pub struct Owners {
    /// Per BVH node, the simplified clusters it owns (indices into the stream's `coarse`; empty
    /// for a scene of static chains).
    pub owned: Vec<Vec<u32>>,
    /// Per BVH node, whether an object under it has triangles outside it.
    pub open: Vec<bool>,
}

/// The owners of the simplified pieces `c.coarse` in `tree`, whose leaves are `c.chunks`; each
/// piece comes with the chunk it lies in (`c.coarse_chunk`).
pub fn owners(tree: &[BvhNode], c: &Chunked) -> Owners {
    let (chunks, coarse, home, objects) = (&c.chunks, &c.coarse, &c.coarse_chunk, c.closed_objects.len());
    let parent = |id: u32| tree[id as usize].parent.expect("not the root");
    // Breadth-first ids: a parent comes before its children.
    let mut depth = vec![0u32; tree.len()];
    for id in 1..tree.len() {
        depth[id] = depth[parent(id as u32) as usize] + 1;
    }
    let lca = |mut a: u32, mut b: u32| {
        while a != b {
            if depth[a as usize] >= depth[b as usize] {
                a = parent(a);
            } else {
                b = parent(b);
            }
        }
        a
    };
    let mut leaf_of = vec![0u32; chunks.len()];
    for (id, n) in tree.iter().enumerate() {
        if let Some(c) = n.item {
            leaf_of[c as usize] = id as u32;
        }
    }
    let leaves = || leaf_of.iter().zip(chunks).map(|(&leaf, c)| (leaf, c.object as usize));
    let mut top: Vec<Option<u32>> = vec![None; objects];
    for (leaf, o) in leaves() {
        top[o] = Some(top[o].map_or(leaf, |t| lca(t, leaf)));
    }
    let mut open = vec![false; tree.len()];
    for (leaf, o) in leaves() {
        let mut n = leaf;
        while Some(n) != top[o] {
            open[n as usize] = true;
            n = parent(n);
        }
    }
    let mut owned = vec![Vec::new(); tree.len()];
    for (k, (piece, &chunk)) in coarse.iter().zip(home).enumerate() {
        let top = top[piece.object as usize].expect("an object with simplified clusters has leaves");
        let mut n = leaf_of[chunk as usize];
        while n != top && !tree[n as usize].bounds.contains(&piece.bounds) {
            n = parent(n);
        }
        owned[n as usize].push(k as u32);
    }
    Owners { owned, open }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aabb::Aabb;
    use crate::build::stream::Chunk;
    use glam::Vec3;

    /// The BVH over chunks `(box, object)` and the owners of `coarse` (box, object, chunk), with
    /// each chunk's leaf.
    fn owners_of(chunks: &[(Aabb, u32)], coarse: &[(Aabb, u32, u32)]) -> (Vec<BvhNode>, Owners, Vec<usize>) {
        let tree = crate::bvh::build(&chunks.iter().map(|c| c.0).collect::<Vec<_>>());
        let d = tempfile::tempdir().unwrap();
        let mut spill = crate::spill::Spill::create(&d.path().join("s.osw")).unwrap();
        let r = spill.append(&crate::clod::Piece::default()).unwrap();
        let at = |b: Aabb, object: u32| Chunk::own(b, object, 1, r);
        let (pieces, home): (Vec<Chunk>, Vec<u32>) = coarse.iter().map(|&(b, o, c)| (at(b, o), c)).unzip();
        let chunked = Chunked {
            chunks: chunks.iter().map(|&(b, o)| at(b, o)).collect(),
            coarse: pieces,
            coarse_chunk: home,
            closed_objects: vec![None; 3],
            origin: glam::DVec3::ZERO,
            prototypes: Default::default(),
            instances: Vec::new(),
        };
        let o = owners(&tree, &chunked);
        let leaf = (0..chunks.len() as u32).map(|item| tree.iter().position(|n| n.item == Some(item)).unwrap()).collect();
        (tree, o, leaf)
    }

    /// A unit box from x to `to`.
    fn unit(x: f32, to: f32) -> Aabb {
        Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(to, 1.0, 1.0))
    }

    /// Four unit boxes along x, of the objects `of`.
    fn four(of: [u32; 4]) -> Vec<(Aabb, u32)> {
        (0..4).map(|i| (unit(i as f32 * 2.0, i as f32 * 2.0 + 1.0), of[i])).collect()
    }

    #[test]
    fn a_piece_goes_to_the_lowest_node_above_its_chunk_holding_it_and_spanning_objects_open_their_nodes() {
        // Object 0 has the first two boxes, object 1 the last two.
        let coarse = [(unit(0.0, 1.0), 0, 0), (unit(0.0, 3.0), 0, 1), (unit(6.0, 7.0), 1, 3)];
        let (tree, o, leaf) = owners_of(&four([0, 0, 1, 1]), &coarse);
        assert_eq!(o.owned[leaf[0]], vec![0]);
        assert_eq!(o.owned[leaf[3]], vec![2]);
        let holder = tree[leaf[0]].parent.unwrap() as usize;
        assert_eq!(o.owned[holder], vec![1], "both halves of object 0");
        assert!(o.open[leaf[0]] && o.open[leaf[1]] && !o.open[holder] && !o.open[0]);
    }

    #[test]
    fn a_piece_goes_up_from_its_chunk_not_down_a_box_that_holds_it_by_spanning_empty_space() {
        // Object 0's chunks lie at both ends of a long wall of object 1: the wall's leaf holds
        // each of object 0's pieces too, but only their own chunks' leaves hold them closely.
        let mut chunks = four([0, 2, 2, 0]);
        chunks.push((Aabb::new(Vec3::new(0.0, 0.0, -1.0), Vec3::new(7.0, 1.0, 1.0)), 1));
        let coarse = [(unit(0.0, 1.0), 0, 0), (unit(6.0, 7.0), 0, 3)];
        let (_, o, leaf) = owners_of(&chunks, &coarse);
        assert_eq!((&o.owned[leaf[0]], &o.owned[leaf[3]]), (&vec![0], &vec![1]));
    }
}
