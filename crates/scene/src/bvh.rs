//! Bounding volume hierarchy over chunks: binned SAH (Wald 2007), binary, one chunk per leaf,
//! nodes numbered breadth first so that the hardware cull's level-by-level batches
//! (occlusion switch sec. 4.7.1) walk ids in order and a parent's id is below its children's.

use crate::aabb::Aabb;
use glam::Vec3;

/// One BVH node. `children` are ids in the same vector; a leaf has none and names its item.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhNode {
    pub bounds: Aabb,
    pub parent: Option<u32>,
    pub children: std::ops::Range<u32>,
    pub item: Option<u32>,
}

/// SAH bins per axis: 16 is the usual sweet spot between build time and tree quality.
const BINS: usize = 16;

/// Builds the BVH over `items` (their boxes); returns nodes in breadth-first order, root at 0.
/// Every node's box contains its children's. `items` must not be empty.
pub fn build(items: &[Aabb]) -> Vec<BvhNode> {
    assert!(!items.is_empty(), "BVH over no items");
    let mut ids: Vec<u32> = (0..items.len() as u32).collect();
    let mut tree = Vec::new();
    let root = build_rec(items, &mut ids, &mut tree);
    breadth_first(&tree, root)
}

/// A node of the recursive build, before renumbering.
struct Tmp {
    bounds: Aabb,
    kids: Option<(usize, usize)>,
    item: u32,
}

fn build_rec(items: &[Aabb], ids: &mut [u32], tree: &mut Vec<Tmp>) -> usize {
    let bounds = ids.iter().fold(Aabb::EMPTY, |b, &i| b.union(items[i as usize]));
    if ids.len() == 1 {
        tree.push(Tmp { bounds, kids: None, item: ids[0] });
        return tree.len() - 1;
    }
    let mid = sah_split(items, ids);
    let (l, r) = ids.split_at_mut(mid);
    let a = build_rec(items, l, tree);
    let b = build_rec(items, r, tree);
    tree.push(Tmp { bounds, kids: Some((a, b)), item: u32::MAX });
    tree.len() - 1
}

/// Partitions `ids` in place and returns the split point (1..len). Uses the SAH over centroid
/// bins on the axis of widest centroid spread; falls back to a median split when all
/// centroids coincide or no bin boundary separates them.
fn sah_split(items: &[Aabb], ids: &mut [u32]) -> usize {
    let centroid = |i: u32| items[i as usize].center();
    let (lo, hi) = ids.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| (lo.min(centroid(i)), hi.max(centroid(i))));
    let axis = (hi - lo).max_position();
    let span = hi[axis] - lo[axis];
    let median = |ids: &mut [u32]| {
        let mid = ids.len() / 2;
        ids.select_nth_unstable_by(mid, |&a, &b| centroid(a)[axis].total_cmp(&centroid(b)[axis]));
        mid
    };
    if span.is_nan() || span <= 0.0 {
        return median(ids);
    }
    let bin_of = |i: u32| (((centroid(i)[axis] - lo[axis]) / span * BINS as f32) as usize).min(BINS - 1);
    let mut bins = [(Aabb::EMPTY, 0usize); BINS];
    for &i in ids.iter() {
        let b = &mut bins[bin_of(i)];
        b.0 = b.0.union(items[i as usize]);
        b.1 += 1;
    }
    // Sweep from the right, then from the left, to cost each of the BINS-1 boundaries.
    let mut right = [(0.0f32, 0usize); BINS];
    let (mut box_r, mut n_r) = (Aabb::EMPTY, 0);
    for k in (1..BINS).rev() {
        box_r = box_r.union(bins[k].0);
        n_r += bins[k].1;
        right[k] = (box_r.half_area(), n_r);
    }
    let (mut box_l, mut n_l) = (Aabb::EMPTY, 0);
    let mut best = (f32::INFINITY, 0);
    for k in 1..BINS {
        box_l = box_l.union(bins[k - 1].0);
        n_l += bins[k - 1].1;
        let (area_r, n_r) = right[k];
        if n_l == 0 || n_r == 0 {
            continue;
        }
        let cost = box_l.half_area() * n_l as f32 + area_r * n_r as f32;
        if cost < best.0 {
            best = (cost, k);
        }
    }
    if best.1 == 0 {
        return median(ids);
    }
    let mut mid = 0;
    for j in 0..ids.len() {
        if bin_of(ids[j]) < best.1 {
            ids.swap(j, mid);
            mid += 1;
        }
    }
    mid
}

fn breadth_first(tree: &[Tmp], root: usize) -> Vec<BvhNode> {
    let mut out: Vec<BvhNode> = Vec::with_capacity(tree.len());
    let mut queue = std::collections::VecDeque::from([(root, None)]);
    while let Some((t, parent)) = queue.pop_front() {
        let id = out.len() as u32;
        let node = &tree[t];
        let item = node.kids.is_none().then_some(node.item);
        out.push(BvhNode { bounds: node.bounds, parent, children: 0..0, item });
        if let Some((a, b)) = node.kids {
            // Children get the next two ids handed out after everything already queued.
            let first = id + queue.len() as u32 + 1;
            out[id as usize].children = first..first + 2;
            queue.push_back((a, Some(id)));
            queue.push_back((b, Some(id)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(x: f32) -> Aabb {
        Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0))
    }

    #[test]
    fn four_boxes_in_a_row_make_a_balanced_tree() {
        // Expected: root over all; children {0,1} and {2,3}; leaves in breadth-first order.
        let items: Vec<Aabb> = [0.0, 1.0, 10.0, 11.0].map(unit_box).to_vec();
        let t = build(&items);
        assert_eq!(t.len(), 7);
        assert_eq!(t[0].children, 1..3);
        assert_eq!(t[1].bounds, Aabb::new(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0)));
        assert_eq!(t[2].bounds, Aabb::new(Vec3::new(10.0, 0.0, 0.0), Vec3::new(12.0, 1.0, 1.0)));
        let mut leaves: Vec<u32> = t.iter().filter_map(|n| n.item).collect();
        leaves.sort();
        assert_eq!(leaves, vec![0, 1, 2, 3]);
    }

    #[test]
    fn identical_boxes_still_split() {
        let items = vec![unit_box(0.0); 5];
        let t = build(&items);
        assert_eq!(t.len(), 9);
        for (id, n) in t.iter().enumerate() {
            for c in n.children.clone() {
                assert_eq!(t[c as usize].parent, Some(id as u32));
                assert!(n.bounds.contains(&t[c as usize].bounds));
            }
        }
    }
}
