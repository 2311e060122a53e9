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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn small_example() {
        // V(i-1) = {1, 2, 5}, V(i) = {2, 3, 5, 9}: added {3, 9}, removed {1}.
        let (mut a, mut r) = (Vec::new(), Vec::new());
        diff(&[1, 2, 5], &[2, 3, 5, 9], &mut a, &mut r);
        assert_eq!((a.as_slice(), r.as_slice()), (&[3, 9][..], &[1][..]));
        assert_eq!(apply(&[1, 2, 5], &r, &a), vec![2, 3, 5, 9]);
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
