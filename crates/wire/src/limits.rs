//! Protocol version and limits, each with its reason.

/// Bumped whenever a message's encoding changes; the handshake refuses a different one.
pub const PROTOCOL_VERSION: u32 = 8;

/// Largest frame payload: a keyframe of every node of a 20M-triangle scene (about 300K ids at
/// up to 5 bytes) fits with room to spare; anything larger is refused before allocating.
pub const MAX_FRAME_BYTES: u32 = 16 << 20;

/// Longest node name and cluster token in a handshake.
pub const MAX_NAME_BYTES: usize = 64;
pub const MAX_TOKEN_BYTES: usize = 256;

/// A connection's writer sends a heartbeat after this long with nothing else to send.
pub const HEARTBEAT: std::time::Duration = std::time::Duration::from_millis(250);

/// A connection silent this long (twelve heartbeats missed) is taken for dead: the survivor
/// runs both roles, the display reads from it (issue 6, failover).
pub const SILENCE: std::time::Duration = std::time::Duration::from_secs(3);

/// Default ids per delta batch (the paper's b, sec. 3.5): HC sends a delta when this many
/// changes are pending, so OR and RVG can start on them while HC goes on.
pub const DEFAULT_BATCH_IDS: usize = 1024;
