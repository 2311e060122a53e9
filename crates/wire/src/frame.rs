//! Frames: `[u32 LE payload length][bincode payload]`. The length is checked against
//! MAX_FRAME_BYTES before anything is allocated; a frame whose payload does not decode to
//! exactly one valid message, with no bytes left over, is refused.

use crate::limits::MAX_FRAME_BYTES;
use crate::messages::Message;

/// What is wrong with bytes from a peer.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum WireError {
    #[error("frame of {len} bytes is over the {max}-byte limit")]
    FrameTooLarge { len: u64, max: u32 },
    #[error("malformed message: {0}")]
    Malformed(String),
    #[error("{0} bytes left over after the message in a frame")]
    TrailingBytes(usize),
    #[error("unusable camera: {0}")]
    BadCamera(String),
    #[error("node id {id} out of range (the scene has {max} nodes)")]
    IdOutOfRange { id: u64, max: u32 },
    #[error("bad id list: {0}")]
    BadIds(String),
}

fn config() -> impl bincode::config::Config {
    bincode::config::standard().with_limit::<{ MAX_FRAME_BYTES as usize }>()
}

/// Appends the frame of `msg` to `out`.
pub fn encode_frame(msg: &Message, out: &mut Vec<u8>) {
    let start = out.len();
    out.extend_from_slice(&[0; 4]);
    // Writing plain data into a Vec cannot fail.
    let payload = bincode::serde::encode_to_vec(msg, config()).expect("messages always encode");
    out.extend_from_slice(&payload);
    let len = (out.len() - start - 4) as u32;
    out[start..start + 4].copy_from_slice(&len.to_le_bytes());
}

/// Bytes of `msg`'s frame on the wire, length prefix included.
pub fn frame_len(msg: &Message) -> usize {
    let mut b = Vec::new();
    encode_frame(msg, &mut b);
    b.len()
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
                token: Some("t".into()),
                serving: true,
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
                stats: HcWireStats { tests: 10, levels: 2, hc_us: 5, pvs: 3, cull_skipped: false },
                clock: LinkStamps { sent_us: 1, camera_received_us: 2, peer_eof_received_us: 3 },
            }),
            Message::Ping(Ping { sent_us: 9 }),
            Message::Pong(Pong { ping_sent_us: 9, received_us: 10, sent_us: 11 }),
            Message::Heartbeat,
            Message::Rejoin(Rejoin { next: 12 }),
            Message::Keyframe(Keyframe { frame: 8, ids: IdList::from_ids(&[0, 1, 2]) }),
            Message::Goodbye(Goodbye { reason: "done".into() }),
        ]
    }

    #[test]
    fn every_message_round_trips() {
        for m in samples() {
            let mut b = Vec::new();
            encode_frame(&m, &mut b);
            assert_eq!(decode_frame(&b).unwrap(), Some((m, b.len())));
        }
    }

    #[test]
    fn golden_bytes_of_version_8() {
        // A change here changes the protocol: bump PROTOCOL_VERSION.
        assert_eq!(crate::limits::PROTOCOL_VERSION, 8);
        // A hello: variant 0, version 1, scene hash 1 and 2, name "a", role 0 (node), token
        // "t", and last the serving flag (protocol 6).
        let mut b = Vec::new();
        encode_frame(&samples()[0], &mut b);
        assert_eq!(b, vec![11, 0, 0, 0, 0, 1, 1, 2, 1, b'a', 0, 1, 1, b't', 1]);
        // An end of frame: length 10, variant 3, frame 7, tests 10, levels 2, hc_us 5, pvs 3,
        // culling not skipped, then the link stamps 1, 2, 3 (bincode standard: varint
        // integers; protocol 7 dropped an OR time that was always 0, protocol 8 added the
        // skipped flag).
        let mut b = Vec::new();
        encode_frame(&samples()[3], &mut b);
        assert_eq!(b, vec![10, 0, 0, 0, 3, 7, 10, 2, 5, 3, 0, 1, 2, 3]);
        // A camera: variant 1, frame 7, eight f64 (position, orientation, fovy) and tau as
        // little-endian IEEE doubles, then sampled_us 123: 2 + 9 * 8 + 1 = 75 bytes, the
        // paper's 72 (sec. 3.5) plus tau, the frame number and the stamp.
        let mut b = Vec::new();
        encode_frame(&samples()[1], &mut b);
        let doubles: Vec<u8> = [1e7, 2.0, -3.5, 0.0, 0.0, 0.0, 1.0, 60.0, 2.5].iter().flat_map(|d: &f64| d.to_le_bytes()).collect();
        assert_eq!(b, [&[75u8, 0, 0, 0, 1, 7][..], &doubles, &[123]].concat());
        // A rejoin: variant 9, the next frame 12.
        let mut b = Vec::new();
        encode_frame(&Message::Rejoin(Rejoin { next: 12 }), &mut b);
        assert_eq!(b, vec![2, 0, 0, 0, 9, 12]);
    }

    #[test]
    fn every_truncation_is_incomplete_never_an_error_or_a_message() {
        for m in samples() {
            let mut b = Vec::new();
            encode_frame(&m, &mut b);
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
        encode_frame(&samples()[5], &mut b);
        b.push(0);
        b[0] += 1;
        assert!(matches!(decode_frame(&b), Err(WireError::TrailingBytes(1))));
        assert!(matches!(decode_frame(&[1, 0, 0, 0, 99]), Err(WireError::Malformed(_))));
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
            );
            assert!(matches!(decode_frame(&b), Err(WireError::BadCamera(_))));
        }
        // A zero quaternion, and finite components whose length overflows (normalising
        // either gives no rotation at all).
        for orientation in [[0.0; 4], [2e200, 0.0, 0.0, 1.0]] {
            let mut b = Vec::new();
            encode_frame(
                &Message::Camera(CameraPacket { frame: 1, position: [0.0; 3], orientation, fovy_deg: 60.0, tau_px: 0.0, sampled_us: 0 }),
                &mut b,
            );
            assert!(matches!(decode_frame(&b), Err(WireError::BadCamera(_))), "{orientation:?}");
        }
    }

    proptest! {
        #[test]
        fn garbage_never_panics(b in proptest::collection::vec(any::<u8>(), 0..256)) {
            let _ = decode_frame(&b);
        }
    }
}
