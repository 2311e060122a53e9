//! osw wire protocol (occlusion switch sec. 3.4-3.5): what the switch nodes and the display send each
//! other over TCP. No GPU and no runtime in the core: [`frame`] turns bytes into [`Message`]s
//! and back. With the `net` feature, `codec` adapts that to tokio-util and `net` makes the
//! connections and the handshake for the binaries; with `config`, `config` reads cluster
//! configuration files and their command-line flags.
//!
//! - [`messages`]: handshake, camera packets, visible-set deltas, end of frame, keyframe,
//!   goodbye. bincode (2.0.1) is used only inside this crate.
//! - [`ids`]: sorted node ids coded as LEB128 varints of their gaps (well under the paper's
//!   4 bytes an id).
//! - [`frame`]: `[u32 LE length][payload]` frames with a maximum size checked before any
//!   allocation; incomplete input is not an error, invalid input is ([`error`]).
//! - [`auth`]: proofs of the cluster token that never send it; with `net`, `tls`: mutual TLS
//!   for links across networks a user does not trust.
//! - [`clock`]: wall-clock stamps and the NTP-style offset estimate for one-way latency.
//! - [`limits`]: the protocol version and the limits, each with its reason.

pub mod auth;
pub mod clock;
#[cfg(feature = "net")]
pub mod codec;
#[cfg(feature = "config")]
pub mod config;
pub mod error;
pub mod frame;
pub mod ids;
pub mod limits;
pub mod messages;
#[cfg(feature = "net")]
pub mod net;
#[cfg(feature = "net")]
pub mod tls;

pub use error::WireError;
pub use frame::{Frame, decode_frame, encode_frame};
pub use messages::{CameraPacket, Delta, EndOfFrame, Goodbye, Hello, IdList, Keyframe, LinkStamps, Message, Ping, Pong, Role};
