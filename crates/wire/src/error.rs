//! What is wrong with bytes from a peer: one error for frames, messages and id lists.

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
