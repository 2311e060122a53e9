//! Free ranges of the vertex arena: first fit, neighbours merged on release. Pure logic.

use std::collections::BTreeMap;

/// Disjoint free ranges `[start, start + len)`, never two adjacent (they are merged).
#[derive(Debug, Default)]
pub struct FreeRanges {
    /// Start -> length.
    free: BTreeMap<u32, u32>,
}

impl FreeRanges {
    /// Takes `len` (> 0) units from the first free range that holds them; its start.
    pub fn take(&mut self, len: u32) -> Option<u32> {
        let (&start, &have) = self.free.iter().find(|&(_, &have)| have >= len)?;
        self.free.remove(&start);
        if have > len {
            self.free.insert(start + len, have - len);
        }
        Some(start)
    }

    /// Whether a range of `len` is free.
    pub fn fits(&self, len: u32) -> bool {
        self.free.values().any(|&have| have >= len)
    }

    /// Gives `[start, start + len)` back (it must not be free), merged with free neighbours.
    pub fn give(&mut self, start: u32, len: u32) {
        if len == 0 {
            return;
        }
        let (mut start, mut len) = (start, len);
        if let Some((&before, &before_len)) = self.free.range(..start).next_back()
            && before + before_len == start
        {
            self.free.remove(&before);
            (start, len) = (before, before_len + len);
        }
        if let Some(after_len) = self.free.remove(&(start + len)) {
            len += after_len;
        }
        self.free.insert(start, len);
    }

    /// Units free in all.
    #[cfg(test)]
    pub fn total(&self) -> u64 {
        self.free.values().map(|&l| l as u64).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn first_fit_and_merge() {
        let mut f = FreeRanges::default();
        f.give(0, 100);
        assert_eq!((f.take(30), f.take(30), f.take(50)), (Some(0), Some(30), None));
        f.give(0, 30);
        assert_eq!(f.take(35), Some(60), "the hole at 0 holds 30, the tail at 60 holds 40");
        f.give(30, 30);
        assert_eq!(f.take(60), Some(0), "0..30 and 30..60 merged");
        assert_eq!(f.total(), 5);
    }

    proptest! {
        /// Any sequence of takes and gives hands out disjoint ranges inside the pool and loses
        /// no unit: free + taken = pool, and after giving everything back one range is left.
        #[test]
        fn taken_ranges_are_disjoint_and_nothing_is_lost(ops in proptest::collection::vec((1u32..40, any::<bool>()), 1..200)) {
            const POOL: u32 = 1000;
            let mut f = FreeRanges::default();
            f.give(0, POOL);
            let mut taken: Vec<(u32, u32)> = Vec::new();
            for (len, give) in ops {
                if give && !taken.is_empty() {
                    let (s, l) = taken.remove(len as usize % taken.len());
                    f.give(s, l);
                } else if let Some(s) = f.take(len) {
                    prop_assert!(s + len <= POOL);
                    prop_assert!(taken.iter().all(|&(t, l)| s + len <= t || t + l <= s), "{s}+{len} overlaps {taken:?}");
                    taken.push((s, len));
                }
                prop_assert_eq!(f.total() + taken.iter().map(|&(_, l)| l as u64).sum::<u64>(), POOL as u64);
            }
            for (s, l) in taken {
                f.give(s, l);
            }
            prop_assert_eq!(f.take(POOL), Some(0));
        }
    }
}
