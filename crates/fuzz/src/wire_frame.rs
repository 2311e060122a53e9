//! Protocol frames from a peer: `decode_frame` refuses or accepts; an accepted message
//! re-encodes to a frame that decodes to the same message, and its id lists decode to sorted,
//! in-range ids that re-encode to the same list.

use osw_wire::messages::{IdList, Message};
use osw_wire::{decode_frame, encode_frame};

/// The scene size ids are checked against.
const MAX_ID: u32 = 100_000;

fn check_ids(list: &IdList) {
    if let Ok(ids) = list.ids(MAX_ID) {
        assert!(ids.windows(2).all(|w| w[0] < w[1]) && ids.iter().all(|&i| i < MAX_ID), "ids accepted out of order or range");
        assert_eq!(IdList::from_ids(&ids).ids(MAX_ID).ok(), Some(ids));
    }
}

pub fn run(data: &[u8]) {
    let Ok(Some((m, used))) = decode_frame(data) else { return };
    assert!(used <= data.len());
    let mut b = Vec::new();
    let n = encode_frame(&m, &mut b).expect("a frame the decoder took re-encodes within the limit");
    assert_eq!(decode_frame(&b).ok(), Some(Some((m.clone(), n))), "re-encoded frame decodes differently");
    match &m {
        Message::Delta(d) => {
            check_ids(&d.added);
            check_ids(&d.removed);
        }
        Message::Keyframe(k) => check_ids(&k.ids),
        _ => {}
    }
}
