//! Node ids on the wire: strictly increasing ids coded as LEB128 varints (integer-encoding)
//! of their gaps: the first id, then `id[k] - id[k-1] - 1`. Visible sets and their deltas
//! cluster in id space (breadth-first BVH ids, a node's LODs adjacent), so most gaps take one
//! or two bytes instead of the paper's four.

use crate::error::WireError;
use integer_encoding::VarInt;

/// Appends the coding of `ids` (sorted, distinct) to `out`.
pub fn encode(ids: &[u32], out: &mut Vec<u8>) {
    let mut prev: Option<u32> = None;
    let mut buf = [0u8; 5];
    for &id in ids {
        let gap = match prev {
            None => id,
            Some(p) => id - p - 1,
        };
        let n = gap.encode_var(&mut buf);
        out.extend_from_slice(&buf[..n]);
        prev = Some(id);
    }
}

/// Splits `ids` (sorted, distinct) into runs whose codings take at most `max_bytes` each
/// (at least one id a run), each run's first id coded whole: the parts of a keyframe.
pub fn split(ids: &[u32], max_bytes: usize) -> Vec<&[u32]> {
    let mut runs = Vec::new();
    let (mut start, mut bytes) = (0, 0);
    for (k, &id) in ids.iter().enumerate() {
        let gap = if k == start { id } else { id - ids[k - 1] - 1 };
        if k > start && bytes + gap.required_space() > max_bytes {
            runs.push(&ids[start..k]);
            (start, bytes) = (k, id.required_space());
        } else {
            bytes += gap.required_space();
        }
    }
    if start < ids.len() {
        runs.push(&ids[start..]);
    }
    runs
}

/// Decodes ids, each below `max_id` (the scene's node count). Refuses truncated or overlong
/// varints and ids out of range.
pub fn decode(bytes: &[u8], max_id: u32) -> Result<Vec<u32>, WireError> {
    let mut out = Vec::with_capacity(bytes.len().min(max_id as usize));
    let mut at = 0;
    let mut next: u64 = 0;
    while at < bytes.len() {
        let (gap, n) = u32::decode_var(&bytes[at..]).ok_or(WireError::BadIds("truncated or overlong varint".into()))?;
        if n > 5 {
            return Err(WireError::BadIds("overlong varint".into()));
        }
        at += n;
        let id = next + gap as u64;
        if id >= max_id as u64 {
            return Err(WireError::IdOutOfRange { id, max: max_id });
        }
        out.push(id as u32);
        next = id + 1;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn small_gaps_take_one_byte() {
        // 1000, 1001, 1003: first id in two bytes, then gaps 0 and 1 in one byte each.
        let mut b = Vec::new();
        encode(&[1000, 1001, 1003], &mut b);
        assert_eq!(b, vec![0xe8, 0x07, 0, 1]);
        assert_eq!(decode(&b, 2000).unwrap(), vec![1000, 1001, 1003]);
    }

    #[test]
    fn refuses_out_of_range_and_truncated() {
        let mut b = Vec::new();
        encode(&[5, 70000], &mut b);
        assert!(matches!(decode(&b, 70000), Err(WireError::IdOutOfRange { id: 70000, max: 70000 })));
        assert!(decode(&b[..b.len() - 1], u32::MAX).is_err());
        assert!(decode(&[0xff; 6], u32::MAX).is_err());
    }

    proptest! {
        #[test]
        fn split_runs_code_within_the_bound_and_join_to_the_ids(
            mut ids in proptest::collection::vec(0u32..1 << 24, 0..2000),
            max in 5usize..200,
        ) {
            ids.sort();
            ids.dedup();
            let runs = split(&ids, max);
            for r in &runs {
                let mut b = Vec::new();
                encode(r, &mut b);
                prop_assert!(!r.is_empty() && b.len() <= max, "{} bytes for {} ids", b.len(), r.len());
            }
            prop_assert_eq!(runs.concat(), ids);
        }

        #[test]
        fn round_trip(mut ids in proptest::collection::vec(0u32..u32::MAX - 1, 0..500)) {
            ids.sort();
            ids.dedup();
            let mut b = Vec::new();
            encode(&ids, &mut b);
            prop_assert_eq!(decode(&b, u32::MAX).unwrap(), ids);
        }

        #[test]
        fn garbage_never_panics(b in proptest::collection::vec(any::<u8>(), 0..64)) {
            if let Ok(ids) = decode(&b, 1 << 20) {
                prop_assert!(ids.windows(2).all(|w| w[0] < w[1]));
            }
        }
    }
}
