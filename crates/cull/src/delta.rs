//! Visible-set deltas (paper 000 sec. 3.4): HC sends δ(i,i-1) = V(i) - V(i-1) (added) and
//! δ(i-1,i) = V(i-1) - V(i) (removed); OR and RVG rebuild V(i) = (V(i-1) - removed) ∪ added.
//! Sets are sorted, distinct id lists.

/// Writes `cur - prev` to `added` and `prev - cur` to `removed` (both sorted).
pub fn diff(prev: &[u32], cur: &[u32], added: &mut Vec<u32>, removed: &mut Vec<u32>) {
    added.clear();
    removed.clear();
    let (mut i, mut j) = (0, 0);
    while i < prev.len() || j < cur.len() {
        match (prev.get(i), cur.get(j)) {
            (Some(a), Some(b)) if a == b => {
                i += 1;
                j += 1;
            }
            (Some(a), Some(b)) if a < b => {
                removed.push(*a);
                i += 1;
            }
            (Some(_), Some(b)) | (None, Some(b)) => {
                added.push(*b);
                j += 1;
            }
            (Some(a), None) => {
                removed.push(*a);
                i += 1;
            }
            (None, None) => unreachable!("loop condition"),
        }
    }
}

/// (prev - removed) ∪ added, sorted. Removed ids not in `prev` and added ids already in it
/// are tolerated (the result is the same set either way).
pub fn apply(prev: &[u32], removed: &[u32], added: &[u32]) -> Vec<u32> {
    let mut out: Vec<u32> = prev.iter().copied().filter(|id| removed.binary_search(id).is_err()).collect();
    out.extend_from_slice(added);
    out.sort_unstable();
    out.dedup();
    out
}

/// Frame i's change in batches of at most `b` added and `b` removed ids (sec. 3.5), so that
/// OR draws the first additions while HC still sends.
pub fn batches<'a>(added: &'a [u32], removed: &'a [u32], b: usize) -> impl Iterator<Item = (&'a [u32], &'a [u32])> {
    let part = move |v: &'a [u32], k: usize| &v[(k * b).min(v.len())..((k + 1) * b).min(v.len())];
    let n = added.len().div_ceil(b).max(removed.len().div_ceil(b));
    (0..n).map(move |k| (part(added, k), part(removed, k)))
}

/// V(i) as the messages of frame i build it (paper 000 sec. 3.4), the same for OR and RVG:
/// batches of deltas against V(i-1), or a keyframe, the whole V(i).
#[derive(Debug, Default)]
pub struct Assembly {
    added: Vec<u32>,
    removed: Vec<u32>,
}

impl Assembly {
    /// A batch of deltas; returns its additions (what OR draws at once).
    pub fn delta(&mut self, added: Vec<u32>, removed: Vec<u32>) -> &[u32] {
        let start = self.added.len();
        self.added.extend(added);
        self.removed.extend(removed);
        &self.added[start..]
    }

    /// A keyframe: V(i) whole, replacing what deltas built so far; returns what it adds to
    /// `previous`, V(i-1).
    pub fn keyframe(&mut self, previous: &[u32], all: &[u32]) -> &[u32] {
        diff(previous, all, &mut self.added, &mut self.removed);
        &self.added
    }

    /// V(i) from `previous`, V(i-1).
    pub fn finish(mut self, previous: &[u32]) -> Vec<u32> {
        self.added.sort_unstable();
        self.removed.sort_unstable();
        apply(previous, &self.removed, &self.added)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn an_assembly_of_batches_or_a_keyframe_gives_the_next_set() {
        let prev = [1, 2, 5, 7];
        let mut a = Assembly::default();
        assert_eq!(a.delta(vec![9], vec![7]), &[9]);
        assert_eq!(a.delta(vec![3], vec![1]), &[3]);
        assert_eq!(a.finish(&prev), vec![2, 3, 5, 9]);
        let mut k = Assembly::default();
        k.delta(vec![4], vec![]);
        assert_eq!(k.keyframe(&prev, &[2, 3, 5, 9]), &[3, 9], "a keyframe replaces earlier batches");
        assert_eq!(k.finish(&prev), vec![2, 3, 5, 9]);
    }

    #[test]
    fn small_example() {
        // V(i-1) = {1, 2, 5}, V(i) = {2, 3, 5, 9}: added {3, 9}, removed {1}.
        let (mut a, mut r) = (Vec::new(), Vec::new());
        diff(&[1, 2, 5], &[2, 3, 5, 9], &mut a, &mut r);
        assert_eq!((a.as_slice(), r.as_slice()), (&[3, 9][..], &[1][..]));
        assert_eq!(apply(&[1, 2, 5], &r, &a), vec![2, 3, 5, 9]);
    }

    #[test]
    fn batches_hold_at_most_b_ids_of_each_kind_additions_first() {
        let (added, removed) = ([1, 2, 3, 4, 5], [8, 9]);
        let b: Vec<_> = batches(&added, &removed, 2).collect();
        assert_eq!(b, vec![(&[1, 2][..], &[8, 9][..]), (&[3, 4][..], &[][..]), (&[5][..], &[][..])]);
        assert_eq!(batches(&[], &[], 2).count(), 0);
        assert_eq!(batches(&[], &removed, 1).map(|(a, r)| (a.len(), r.len())).collect::<Vec<_>>(), vec![(0, 1), (0, 1)]);
    }

    proptest! {
        #[test]
        fn apply_of_diff_rebuilds_the_set(prev in proptest::collection::btree_set(0u32..200, 0..80), cur in proptest::collection::btree_set(0u32..200, 0..80)) {
            let (prev, cur): (Vec<u32>, Vec<u32>) = (prev.into_iter().collect(), cur.into_iter().collect());
            let (mut a, mut r) = (Vec::new(), Vec::new());
            diff(&prev, &cur, &mut a, &mut r);
            prop_assert_eq!(apply(&prev, &r, &a), cur.clone());
            prop_assert!(a.iter().all(|x| !prev.contains(x)) && r.iter().all(|x| !cur.contains(x)));
        }
    }
}
