//! Visible-set deltas (occlusion switch sec. 3.4): HC sends δ(i,i-1) = V(i) - V(i-1) (added) and
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

/// V(i) as the messages of frame i build it (occlusion switch sec. 3.4), the same for OR and RVG:
/// batches of deltas against V(i-1), or a keyframe, the whole V(i).
#[derive(Debug, Default)]
pub struct Assembly {
    added: Vec<u32>,
    removed: Vec<u32>,
    keyframe: Option<KeyframeParts>,
}

/// A keyframe as its parts come.
#[derive(Debug)]
struct KeyframeParts {
    /// The ids so far, and the additions of deltas after it.
    all: Vec<u32>,
    next: u32,
    parts: u32,
}

impl Assembly {
    /// A batch of deltas; returns its additions (what OR draws at once).
    pub fn delta(&mut self, added: Vec<u32>, removed: Vec<u32>) -> &[u32] {
        if let Some(k) = self.keyframe.as_mut() {
            k.all.extend_from_slice(&added);
        }
        let start = self.added.len();
        self.added.extend(added);
        self.removed.extend(removed);
        &self.added[start..]
    }

    /// Part `part` of `parts` of a keyframe, the next run of V(i)'s sorted ids; its first part
    /// replaces what came before. Returns what the part adds to `previous`, V(i-1). A part out
    /// of order is an error.
    pub fn keyframe(&mut self, previous: &[u32], part: u32, parts: u32, ids: Vec<u32>) -> Result<&[u32], DeltaError> {
        if part == 0 {
            self.keyframe = Some(KeyframeParts { all: Vec::new(), next: 0, parts });
            self.added.clear();
            self.removed.clear();
        }
        let k = match self.keyframe.as_mut() {
            Some(k) if k.next == part && k.parts == parts => k,
            k => return Err(DeltaError::OutOfOrder { part, parts, after: k.map(|k| (k.next, k.parts)) }),
        };
        if let (Some(&last), Some(&first)) = (k.all.last(), ids.first())
            && first <= last
        {
            return Err(DeltaError::Unsorted { part, parts, first, last });
        }
        k.next += 1;
        k.all.extend_from_slice(&ids);
        let start = self.added.len();
        self.added.extend(ids.into_iter().filter(|id| previous.binary_search(id).is_err()));
        Ok(&self.added[start..])
    }

    /// V(i) from `previous`, V(i-1); an error where a keyframe stopped short of its last part.
    pub fn finish(mut self, previous: &[u32]) -> Result<Vec<u32>, DeltaError> {
        self.removed.sort_unstable();
        if let Some(mut k) = self.keyframe {
            if k.next != k.parts {
                return Err(DeltaError::Short { parts: k.parts, came: k.next });
            }
            k.all.sort_unstable();
            k.all.dedup();
            return Ok(apply(&k.all, &self.removed, &[]));
        }
        self.added.sort_unstable();
        Ok(apply(previous, &self.removed, &self.added))
    }
}

/// Why the keyframe parts of a frame do not make its visible set ([`Assembly`]).
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
pub enum DeltaError {
    /// `after` is the part expected next and the parts of the keyframe under way, if any.
    #[error("keyframe part {part} of {parts} after {after:?}")]
    OutOfOrder { part: u32, parts: u32, after: Option<(u32, u32)> },
    #[error("keyframe part {part} of {parts} starts at id {first}, not after {last}")]
    Unsorted { part: u32, parts: u32, first: u32, last: u32 },
    #[error("a keyframe ended after {came} of its {parts} parts")]
    Short { parts: u32, came: u32 },
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
        assert_eq!(a.finish(&prev).unwrap(), vec![2, 3, 5, 9]);
        let mut k = Assembly::default();
        k.delta(vec![4], vec![]);
        assert_eq!(k.keyframe(&prev, 0, 1, vec![2, 3, 5, 9]).unwrap(), &[3, 9], "a keyframe replaces earlier batches");
        assert_eq!(k.finish(&prev).unwrap(), vec![2, 3, 5, 9]);
    }

    #[test]
    fn a_keyframe_in_parts_gives_the_next_set_and_refuses_parts_out_of_order() {
        let prev = [1, 2, 5, 7];
        let mut k = Assembly::default();
        assert_eq!(k.keyframe(&prev, 0, 3, vec![2, 3]).unwrap(), &[3]);
        assert_eq!(k.keyframe(&prev, 1, 3, vec![5]).unwrap(), &[] as &[u32]);
        assert_eq!(k.keyframe(&prev, 2, 3, vec![9, 11]).unwrap(), &[9, 11]);
        assert_eq!(k.finish(&prev).unwrap(), vec![2, 3, 5, 9, 11]);
        let mut short = Assembly::default();
        short.keyframe(&prev, 0, 2, vec![2]).unwrap();
        assert!(short.finish(&prev).unwrap_err().to_string().contains("1 of its 2 parts"));
        let mut skipped = Assembly::default();
        assert!(skipped.keyframe(&prev, 1, 2, vec![2]).is_err(), "a second part first");
        skipped.keyframe(&prev, 0, 2, vec![5]).unwrap();
        assert!(skipped.keyframe(&prev, 1, 2, vec![3]).is_err(), "ids not after the first part's");
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
