//! Frames: `[u32 LE payload length][bincode payload]`. The length is checked against
//! MAX_FRAME_BYTES before anything is allocated; a frame whose payload does not decode to
//! exactly one valid message, with no bytes left over, is refused.

use crate::error::WireError;
use crate::limits::MAX_FRAME_BYTES;
use crate::messages::Message;

/// bincode's bound on what a payload's lengths may make it allocate, so that a forged length
/// allocates nothing large: the length prefix bounds the payload to MAX_FRAME_BYTES, and
/// bincode counts a serde string's bytes twice (read, then made a String), so twice that.
fn config() -> impl bincode::config::Config {
    bincode::config::standard().with_limit::<{ 2 * MAX_FRAME_BYTES as usize }>()
}

/// Appends the frame of `msg` to `out` and returns its bytes on the wire, length prefix
/// included. A message whose payload the decoder would refuse (over [`MAX_FRAME_BYTES`]) is
/// refused here, and `out` is left as it was: a sender learns it before its peer drops the link.
pub fn encode_frame(msg: &Message, out: &mut Vec<u8>) -> Result<usize, WireError> {
    let start = out.len();
    out.extend_from_slice(&[0; 4]);
    // Writing plain data into a Vec cannot fail.
    bincode::serde::encode_into_std_write(msg, out, config()).expect("a Vec takes every write");
    let len = (out.len() - start - 4) as u64;
    if len > MAX_FRAME_BYTES as u64 {
        out.truncate(start);
        return Err(WireError::FrameTooLarge { len, max: MAX_FRAME_BYTES });
    }
    out[start..start + 4].copy_from_slice(&(len as u32).to_le_bytes());
    Ok(4 + len as usize)
}

/// One message encoded once: what a connection's writer sends, its bytes counted where it was
/// made.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Frame(Vec<u8>);

impl Frame {
    pub fn new(msg: &Message) -> Result<Frame, WireError> {
        let mut b = Vec::new();
        encode_frame(msg, &mut b)?;
        Ok(Frame(b))
    }

    /// Bytes on the wire, length prefix included.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn bytes(&self) -> &[u8] {
        &self.0
    }
}

/// Decodes one frame from the front of `buf`: `Ok(None)` when the frame is incomplete,
/// `Ok(Some((message, bytes used)))`, or the error that makes the stream unusable.
pub fn decode_frame(buf: &[u8]) -> Result<Option<(Message, usize)>, WireError> {
    let Some(head) = buf.get(..4) else { return Ok(None) };
    let len = u32::from_le_bytes(head.try_into().expect("4 bytes"));
    if len > MAX_FRAME_BYTES {
        return Err(WireError::FrameTooLarge { len: len as u64, max: MAX_FRAME_BYTES });
    }
    let Some(payload) = buf.get(4..4 + len as usize) else { return Ok(None) };
    let (msg, used): (Message, usize) =
        bincode::serde::decode_from_slice(payload, config()).map_err(|e| WireError::Malformed(e.to_string()))?;
    if used != payload.len() {
        return Err(WireError::TrailingBytes(payload.len() - used));
    }
    msg.validate()?;
    Ok(Some((msg, 4 + len as usize)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::messages::*;
    use proptest::prelude::*;

    fn samples() -> Vec<Message> {
        vec![
            Message::Hello(Hello {
                version: 1,
                scene_hash: [1, 2],
                name: "a".into(),
                role: Role::Node,
                serving: true,
                settings: vec![("--size".into(), "8x8".into())],
                session: 5,
                tag: [7; 32],
            }),
            Message::Camera(CameraPacket {
                frame: 7,
                position: [1e7, 2.0, -3.5],
                orientation: [0.0, 0.0, 0.0, 1.0],
                fovy_deg: 60.0,
                tau_px: 2.5,
                sampled_us: 123,
            }),
            Message::Delta(Delta { frame: 7, added: IdList::from_ids(&[1, 5, 900]), removed: IdList::from_ids(&[2]) }),
            Message::EndOfFrame(EndOfFrame {
                frame: 7,
                stats: HcWireStats { tests: 10, levels: 2, hc_us: 5, passes_us: [3, 1, 1], pvs: 3, cull_skipped: false, degraded: true },
                clock: LinkStamps {
                    sent_us: 1,
                    camera_received_us: 2,
                    peer_eof_received_us: 3,
                    peer_sent_us: 4,
                    or_start_us: 5,
                    or_end_us: 6,
                    hc_start_us: 7,
                },
            }),
            Message::Ping(Ping { sent_us: 9 }),
            Message::Pong(Pong { ping_sent_us: 9, received_us: 10, sent_us: 11 }),
            Message::Heartbeat,
            Message::Rejoin(Rejoin { next: 12 }),
            Message::Keyframe(Keyframe { frame: 8, part: 1, parts: 2, ids: IdList::from_ids(&[0, 1, 2]) }),
            Message::Goodbye(Goodbye { reason: "done".into() }),
            Message::StartOver(StartOver { session: 1 }),
            Message::Clusters(ClusterMask { frame: 7, bits: vec![5, 0x80] }),
            Message::Challenge(Challenge { version: 12, nonce: [3; 32] }),
            Message::Proof(Proof { tag: [4; 32] }),
        ]
    }

    #[test]
    fn every_message_round_trips() {
        for m in samples() {
            let mut b = Vec::new();
            let n = encode_frame(&m, &mut b).unwrap();
            assert_eq!(decode_frame(&b).unwrap(), Some((m, n)));
        }
    }

    #[test]
    fn golden_bytes_of_version_13() {
        // A change here changes the protocol: bump PROTOCOL_VERSION.
        assert_eq!(crate::limits::PROTOCOL_VERSION, 13);
        // A hello: variant 0, version 1, scene hash 1 and 2, name "a", role 0 (node), the
        // serving flag (protocol 6), the settings (protocol 9): one, "--size" "8x8", the
        // display's session 5 and the hello's tag (protocol 12, which no longer sends a token).
        let mut b = Vec::new();
        encode_frame(&samples()[0], &mut b).unwrap();
        assert_eq!(b, [&[53, 0, 0, 0, 0, 1, 1, 2, 1, b'a', 0, 1, 1, 6][..], b"--size", &[3], b"8x8", &[5], &[7; 32]].concat());
        // A challenge (protocol 12): variant 12, the version, a nonce of 32 bytes; a proof:
        // variant 13, its tag of 32.
        let mut b = Vec::new();
        encode_frame(&samples()[12], &mut b).unwrap();
        assert_eq!(b, [&[34, 0, 0, 0, 12, 12][..], &[3; 32]].concat());
        let mut b = Vec::new();
        encode_frame(&samples()[13], &mut b).unwrap();
        assert_eq!(b, [&[33, 0, 0, 0, 13][..], &[4; 32]].concat());
        // An end of frame: length 18, variant 3, frame 7, tests 10, levels 2, hc_us 5, HC's
        // passes 3, 1, 1 (protocol 9), pvs 3, culling not skipped, degraded, then the link
        // stamps 1, 2, 3, 4 and the stage stamps 5, 6, 7 (bincode standard: varint integers;
        // protocol 7 dropped an OR time that was always 0, protocol 8 added the skipped flag,
        // protocol 11 when the peer's copy went, protocol 12 the degraded flag, protocol 13
        // when OR took the camera and ended and when HC began).
        let mut b = Vec::new();
        encode_frame(&samples()[3], &mut b).unwrap();
        assert_eq!(b, vec![18, 0, 0, 0, 3, 7, 10, 2, 5, 3, 1, 1, 3, 0, 1, 1, 2, 3, 4, 5, 6, 7]);
        // A camera: variant 1, frame 7, eight f64 (position, orientation, fovy) and tau as
        // little-endian IEEE doubles, then sampled_us 123: 2 + 9 * 8 + 1 = 75 bytes, the
        // paper's 72 (sec. 3.5) plus tau, the frame number and the stamp.
        let mut b = Vec::new();
        encode_frame(&samples()[1], &mut b).unwrap();
        let doubles: Vec<u8> = [1e7, 2.0, -3.5, 0.0, 0.0, 0.0, 1.0, 60.0, 2.5].iter().flat_map(|d: &f64| d.to_le_bytes()).collect();
        assert_eq!(b, [&[75u8, 0, 0, 0, 1, 7][..], &doubles, &[123]].concat());
        // A rejoin: variant 9, the next frame 12.
        let mut b = Vec::new();
        encode_frame(&Message::Rejoin(Rejoin { next: 12 }), &mut b).unwrap();
        assert_eq!(b, vec![2, 0, 0, 0, 9, 12]);
        // A start over (protocol 10; a session since protocol 12): variant 10, session 1.
        let mut b = Vec::new();
        encode_frame(&Message::StartOver(StartOver { session: 1 }), &mut b).unwrap();
        assert_eq!(b, vec![2, 0, 0, 0, 10, 1]);
        // A keyframe: variant 4, frame 8, part 1 of 2 (protocol 9), the ids' 3 bytes.
        let mut b = Vec::new();
        encode_frame(&samples()[8], &mut b).unwrap();
        assert_eq!(b, vec![8, 0, 0, 0, 4, 8, 1, 2, 3, 0, 0, 0]);
        // HC's cluster mask (protocol 11): variant 11, frame 7, its 2 bytes.
        let mut b = Vec::new();
        encode_frame(&samples()[11], &mut b).unwrap();
        assert_eq!(b, vec![5, 0, 0, 0, 11, 7, 2, 5, 0x80]);
    }

    #[test]
    fn a_keyframe_over_the_limit_crosses_in_parts() {
        // Every node of a scene of 17M: one byte an id, over the frame limit whole.
        let ids: Vec<u32> = (0..MAX_FRAME_BYTES + (1 << 20)).collect();
        let whole = Message::Keyframe(Keyframe { frame: 3, part: 0, parts: 1, ids: IdList::from_ids(&ids) });
        assert!(matches!(Frame::new(&whole), Err(WireError::FrameTooLarge { .. })));
        let parts = Keyframe::parts(3, &ids, crate::limits::KEYFRAME_PART_BYTES);
        assert_eq!(parts.len(), 2);
        let mut got = Vec::new();
        for (k, p) in parts.iter().enumerate() {
            let f = Frame::new(p).unwrap();
            let Some((Message::Keyframe(m), _)) = decode_frame(f.bytes()).unwrap() else { panic!("part {k}") };
            assert_eq!((m.frame, m.part, m.parts), (3, k as u32, 2));
            got.extend(m.ids.ids(u32::MAX).unwrap());
        }
        assert!(got == ids, "the parts join to V(i)");
        assert_eq!(Keyframe::parts(3, &[], 100).len(), 1, "an empty set is one empty part");
    }

    #[test]
    fn every_truncation_is_incomplete_never_an_error_or_a_message() {
        for m in samples() {
            let mut b = Vec::new();
            encode_frame(&m, &mut b).unwrap();
            for n in 0..b.len() {
                assert_eq!(decode_frame(&b[..n]), Ok(None), "{m:?} cut at {n}");
            }
        }
    }

    #[test]
    fn refuses_oversized_trailing_unknown_and_bad_cameras() {
        let big = (MAX_FRAME_BYTES + 1).to_le_bytes();
        assert!(matches!(decode_frame(&big), Err(WireError::FrameTooLarge { .. })));
        let mut b = Vec::new();
        encode_frame(&samples()[5], &mut b).unwrap();
        b.push(0);
        b[0] += 1;
        assert!(matches!(decode_frame(&b), Err(WireError::TrailingBytes(1))));
        assert!(matches!(decode_frame(&[1, 0, 0, 0, 99]), Err(WireError::Malformed(_))));
        assert!(matches!(decode_frame(&[5, 0, 0, 0, 4, 8, 2, 2, 0]), Err(WireError::Malformed(_))), "part 2 of 2");
        for bad in [[f64::NAN, 0.0, 0.0], [f64::INFINITY, 0.0, 0.0]] {
            let mut b = Vec::new();
            encode_frame(
                &Message::Camera(CameraPacket {
                    frame: 1,
                    position: bad,
                    orientation: [0.0, 0.0, 0.0, 1.0],
                    fovy_deg: 60.0,
                    tau_px: 0.0,
                    sampled_us: 0,
                }),
                &mut b,
            )
            .unwrap();
            assert!(matches!(decode_frame(&b), Err(WireError::BadCamera(_))));
        }
        // A zero quaternion, and finite components whose length overflows (normalising
        // either gives no rotation at all).
        for orientation in [[0.0; 4], [2e200, 0.0, 0.0, 1.0]] {
            let mut b = Vec::new();
            encode_frame(
                &Message::Camera(CameraPacket { frame: 1, position: [0.0; 3], orientation, fovy_deg: 60.0, tau_px: 0.0, sampled_us: 0 }),
                &mut b,
            )
            .unwrap();
            assert!(matches!(decode_frame(&b), Err(WireError::BadCamera(_))), "{orientation:?}");
        }
    }

    #[test]
    fn the_encoder_refuses_one_byte_over_the_limit_and_keeps_what_it_had() {
        // A goodbye's payload is its variant, the reason's length (a 5-byte varint at this
        // size) and the reason: a reason of MAX - 6 bytes makes a payload of exactly MAX.
        let goodbye = |n: usize| Message::Goodbye(Goodbye { reason: "x".repeat(n) });
        let max = MAX_FRAME_BYTES as usize;
        let mut b = vec![7];
        assert_eq!(encode_frame(&goodbye(max - 6), &mut b), Ok(4 + max));
        let got = decode_frame(&b[1..]);
        assert!(matches!(got, Ok(Some((_, n))) if n == 4 + max), "the largest frame decodes: {:?}", got.map(|m| m.map(|m| m.1)));
        b.truncate(1);
        assert_eq!(encode_frame(&goodbye(max - 5), &mut b), Err(WireError::FrameTooLarge { len: max as u64 + 1, max: MAX_FRAME_BYTES }));
        assert_eq!(b, vec![7], "a refused frame leaves nothing behind");
        assert!(Frame::new(&goodbye(max - 5)).is_err());
        // The same for ids: a keyframe's variant, frame, part, parts and the list's length take
        // 1 + 1 + 1 + 1 + 5 bytes.
        let keyframe = |n: usize| Message::Keyframe(Keyframe { frame: 0, part: 0, parts: 1, ids: IdList(vec![0; n]) });
        let f = Frame::new(&keyframe(max - 9)).unwrap();
        assert!(matches!(decode_frame(f.bytes()), Ok(Some((_, n))) if n == 4 + max));
        assert!(matches!(Frame::new(&keyframe(max - 8)), Err(WireError::FrameTooLarge { .. })));
    }

    proptest! {
        #[test]
        fn garbage_never_panics(b in proptest::collection::vec(any::<u8>(), 0..256)) {
            let _ = decode_frame(&b);
        }
    }
}
