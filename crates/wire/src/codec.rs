//! The frames as a tokio-util codec, for the binaries' sockets.

use crate::error::WireError;
use crate::frame::{Frame, decode_frame, encode_frame};
use crate::messages::Message;
use bytes::{Buf, BytesMut};

/// Decodes [`Message`] frames, each with its bytes on the wire, and encodes messages and
/// [`Frame`]s.
#[derive(Clone, Copy, Debug, Default)]
pub struct WireCodec;

/// Socket errors and protocol errors, apart.
#[derive(Debug, thiserror::Error)]
pub enum CodecError {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Wire(#[from] WireError),
}

impl tokio_util::codec::Decoder for WireCodec {
    type Item = (Message, usize);
    type Error = CodecError;

    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<(Message, usize)>, CodecError> {
        match decode_frame(src)? {
            Some((msg, used)) => {
                src.advance(used);
                Ok(Some((msg, used)))
            }
            None => Ok(None),
        }
    }
}

impl tokio_util::codec::Encoder<Message> for WireCodec {
    type Error = CodecError;

    fn encode(&mut self, msg: Message, dst: &mut BytesMut) -> Result<(), CodecError> {
        let mut v = Vec::new();
        encode_frame(&msg, &mut v)?;
        dst.extend_from_slice(&v);
        Ok(())
    }
}

impl tokio_util::codec::Encoder<Frame> for WireCodec {
    type Error = CodecError;

    fn encode(&mut self, frame: Frame, dst: &mut BytesMut) -> Result<(), CodecError> {
        dst.extend_from_slice(frame.bytes());
        Ok(())
    }
}
