//! Where a cluster hierarchy's simplified groups go in the BVH: each to the lowest node below
//! its object's lowest common ancestor whose box holds it, so that V(i) stays a set of node ids
//! and a node's box bounds everything it draws (HC's occlusion tests stay conservative). A
//! group's vertices are vertices of its object's original triangles, so the ancestor's box
//! holds it.
//!
//! A node's HLOD stands for its whole subtree, so it may only be built where no object under
//! the node reaches outside it: otherwise a coarse group of that object, owned above, and the
//! HLOD could both be drawn over the same surface.

use crate::bvh::BvhNode;
use crate::stream::Chunk;

pub struct Owners {
    /// Per BVH node, the simplified groups it owns (indices into the stream's `coarse`; empty
    /// for a scene of static chains).
    pub owned: Vec<Vec<u32>>,
    /// Per BVH node, whether an object under it has triangles outside it.
    pub open: Vec<bool>,
}

/// The owners of `coarse` in `tree`, whose leaves are `chunks`.
pub fn owners(tree: &[BvhNode], chunks: &[Chunk], coarse: &[Chunk], objects: usize) -> Owners {
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
    let leaves = || tree.iter().enumerate().filter_map(|(id, n)| n.item.map(|c| (id as u32, chunks[c as usize].object as usize)));
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
    for (k, piece) in coarse.iter().enumerate() {
        let mut n = top[piece.object as usize].expect("an object with simplified groups has leaves");
        while let Some(c) = tree[n as usize].children.clone().find(|&c| tree[c as usize].bounds.contains(&piece.bounds)) {
            n = c;
        }
        owned[n as usize].push(k as u32);
    }
    Owners { owned, open }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aabb::Aabb;
    use glam::Vec3;

    #[test]
    fn a_group_goes_to_the_lowest_node_holding_it_and_spanning_objects_open_their_nodes() {
        // Four unit boxes along x; object 0 has the first two, object 1 the last two.
        let boxes: Vec<Aabb> =
            (0..4).map(|i| Aabb::new(Vec3::new(i as f32 * 2.0, 0.0, 0.0), Vec3::new(i as f32 * 2.0 + 1.0, 1.0, 1.0))).collect();
        let tree = crate::bvh::build(&boxes);
        let d = tempfile::tempdir().unwrap();
        let mut spill = crate::spill::Spill::create(&d.path().join("s.osw")).unwrap();
        let r = spill.append(&crate::clod::Piece::default()).unwrap();
        let at = |b: Aabb, object: u32| Chunk::own(b, object, 1, r);
        let chunks: Vec<Chunk> = boxes.iter().enumerate().map(|(i, &b)| at(b, i as u32 / 2)).collect();
        let coarse = [at(boxes[0], 0), at(boxes[0].union(boxes[1]), 0), at(boxes[3], 1)];
        let o = owners(&tree, &chunks, &coarse, 2);
        let leaf_of = |item: u32| tree.iter().position(|n| n.item == Some(item)).unwrap();
        assert_eq!(o.owned[leaf_of(0)], vec![0]);
        assert_eq!(o.owned[leaf_of(3)], vec![2]);
        let holder = tree[leaf_of(0)].parent.unwrap() as usize;
        assert_eq!(o.owned[holder], vec![1], "both halves of object 0");
        assert!(o.open[leaf_of(0)] && o.open[leaf_of(1)] && !o.open[holder] && !o.open[0]);
    }
}
