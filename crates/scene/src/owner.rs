//! Where a cluster hierarchy's simplified clusters go in the BVH: each piece of one (what of
//! it lies in one chunk, see [`crate::clod`]) to its chunk's leaf or the lowest node above it
//! whose box holds it once grown a little ([`SLACK`]), so that V(i) stays a set of node ids; the
//! boxes are grown to what their nodes own, so a node's box bounds everything it draws (HC's
//! occlusion tests stay conservative). A piece's vertices are vertices of its object's
//! original triangles, so the object's lowest common ancestor holds it.
//!
//! A node's HLOD stands for its whole subtree, so it may only be built where no object under
//! the node reaches outside it: otherwise a coarse cluster of that object, owned above, and the
//! HLOD could both be drawn over the same surface, or a cluster owned below, which the HLOD
//! does not hold, not at all.

use crate::aabb::Aabb;
use crate::bvh::BvhNode;
use crate::stream::Chunk;

pub struct Owners {
    /// Per BVH node, the simplified clusters it owns (indices into the stream's `coarse`; empty
    /// for a scene of static chains).
    pub owned: Vec<Vec<u32>>,
    /// Per BVH node, whether an object under it has triangles outside it.
    pub open: Vec<bool>,
    /// Per BVH node, its box grown to hold the simplified clusters it and its subtree own.
    pub bounds: Vec<Aabb>,
}

/// How much a node's box may grow, in surface area, to own a simplified piece that crosses its
/// border. A piece lies in one chunk but its triangles reach into the next; held only by a node
/// that contains it, it would sit wherever a split plane of the BVH crosses it, often near the
/// root, where HC's box tests seldom cull. A box grown a little keeps it at its chunk's leaf.
const SLACK: f32 = 0.25;

/// The owners of `coarse` in `tree`, whose leaves are `chunks`; the coarse pieces come with
/// the chunk each lies in.
pub fn owners(tree: &[BvhNode], chunks: &[Chunk], (coarse, home): (&[Chunk], &[u32]), objects: usize) -> Owners {
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
    // From the piece's chunk up: its object's ancestor holds it (see the top).
    let mut owned = vec![Vec::new(); tree.len()];
    let mut grown: Vec<Aabb> = tree.iter().map(|n| n.bounds).collect();
    for (k, (piece, &chunk)) in coarse.iter().zip(home).enumerate() {
        let mut n = leaf_of[chunk as usize];
        let top = top[piece.object as usize].expect("an object with simplified clusters has leaves");
        while n != top && grown[n as usize].union(piece.bounds).half_area() > (1.0 + SLACK) * tree[n as usize].bounds.half_area() {
            n = parent(n);
        }
        grown[n as usize] = grown[n as usize].union(piece.bounds);
        owned[n as usize].push(k as u32);
    }
    // Breadth-first ids: children after their parent, so each box is grown after its children's.
    for id in (1..tree.len()).rev() {
        let p = parent(id as u32) as usize;
        grown[p] = grown[p].union(grown[id]);
    }
    Owners { owned, open, bounds: grown }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Four unit boxes along x, one chunk each, of the objects `of`; the owners of `coarse`
    /// (box, object, chunk) and each chunk's leaf.
    fn four(of: [u32; 4], coarse: &[(Aabb, u32, u32)]) -> (Vec<BvhNode>, Owners, Vec<usize>) {
        let boxes: Vec<Aabb> = (0..4).map(|i| unit(i as f32 * 2.0, i as f32 * 2.0 + 1.0)).collect();
        let tree = crate::bvh::build(&boxes);
        let d = tempfile::tempdir().unwrap();
        let mut spill = crate::spill::Spill::create(&d.path().join("s.osw")).unwrap();
        let r = spill.append(&crate::clod::Piece::default()).unwrap();
        let at = |b: Aabb, object: u32| Chunk::own(b, object, 1, r);
        let chunks: Vec<Chunk> = boxes.iter().zip(of).map(|(&b, o)| at(b, o)).collect();
        let (pieces, home): (Vec<Chunk>, Vec<u32>) = coarse.iter().map(|&(b, o, c)| (at(b, o), c)).unzip();
        let o = owners(&tree, &chunks, (&pieces, &home), 3);
        let leaves = (0..4).map(|item| tree.iter().position(|n| n.item == Some(item)).unwrap()).collect();
        (tree, o, leaves)
    }

    fn unit(x: f32, to: f32) -> Aabb {
        Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(to, 1.0, 1.0))
    }

    #[test]
    fn a_piece_goes_to_the_lowest_node_holding_it_and_spanning_objects_open_their_nodes() {
        // Object 0 has the first two boxes, object 1 the last two.
        let (tree, o, leaf) = four([0, 0, 1, 1], &[(unit(0.0, 1.0), 0, 0), (unit(0.0, 3.0), 0, 1), (unit(6.0, 7.0), 1, 3)]);
        assert_eq!(o.owned[leaf[0]], vec![0]);
        assert_eq!(o.owned[leaf[3]], vec![2]);
        let holder = tree[leaf[0]].parent.unwrap() as usize;
        assert_eq!(o.owned[holder], vec![1], "both halves of object 0");
        assert!(o.open[leaf[0]] && o.open[leaf[1]] && !o.open[holder] && !o.open[0]);
        assert!(o.bounds.iter().zip(&tree).all(|(b, n)| *b == n.bounds), "nothing crosses a border");
    }

    #[test]
    fn a_piece_just_over_its_chunks_border_grows_the_boxes_above_it() {
        // Object 0 has the outer boxes. A piece of it a tenth over box 0's border goes to box
        // 0 (its box and those above grown to hold it); one over the first two boxes to the
        // node above them, open, and one over three to the object's ancestor, the root.
        let pieces = [(unit(0.0, 1.1), 0, 0), (unit(0.0, 3.0), 0, 0), (unit(0.0, 5.0), 0, 0)];
        let (tree, o, leaf) = four([0, 1, 2, 0], &pieces);
        assert_eq!(o.owned[leaf[0]], vec![0]);
        assert_eq!(o.owned[tree[leaf[0]].parent.unwrap() as usize], vec![1]);
        assert_eq!(o.owned[0], vec![2]);
        assert_eq!(o.bounds[leaf[0]], unit(0.0, 1.1));
        let mut n = leaf[0];
        while let Some(p) = tree[n].parent {
            assert!(o.bounds[p as usize].contains(&o.bounds[n]) && o.open[n], "node {n}");
            n = p as usize;
        }
        assert!(!o.open[leaf[1]] && !o.open[leaf[2]] && !o.open[0]);
    }
}
