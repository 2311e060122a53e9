//! Protocol version and limits, each with its reason.

/// Bumped whenever a message's encoding changes; the handshake refuses a different one.
pub const PROTOCOL_VERSION: u32 = 13;

/// Largest frame payload, refused before allocating by the decoder and before sending by the
/// encoder. Every message but a keyframe is small (a delta holds at most b ids of each kind at
/// up to 5 bytes: 10 KiB at the default b); a keyframe goes in parts of at most
/// [`KEYFRAME_PART_BYTES`], so that V(i) of any scene crosses: the 1B-triangle plant's 14.6M
/// nodes code in about 15 MB dense, 73 MB at worst.
pub const MAX_FRAME_BYTES: u32 = 16 << 20;

/// Largest coding of a keyframe part's ids: a part's other fields (variant, frame, part,
/// parts, the list's length) take at most 1 + 10 + 5 + 5 + 10 bytes.
pub const KEYFRAME_PART_BYTES: usize = MAX_FRAME_BYTES as usize - 32;

/// Longest node name in a handshake.
pub const MAX_NAME_BYTES: usize = 64;

/// Most settings a hello carries (osw says 5), each flag and value within MAX_NAME_BYTES.
pub const MAX_SETTINGS: usize = 32;

/// Longest wait of a node or the display for the next frame's messages, and of the display
/// for the nodes to connect, unless `--frame-timeout` says otherwise: a first frame at full
/// detail of a huge scene may need more.
pub const FRAME_WAIT: std::time::Duration = std::time::Duration::from_secs(30);

/// Longest wait for each step of a handshake (TLS, then osw's): a peer that says nothing is
/// dropped after it.
pub const HANDSHAKE: std::time::Duration = std::time::Duration::from_secs(10);

/// A connection's writer sends a heartbeat after this long with nothing else to send.
pub const HEARTBEAT: std::time::Duration = std::time::Duration::from_millis(250);

/// A connection silent this long (twelve heartbeats missed) is taken for dead: the survivor
/// runs both roles, the display reads from it (failover).
pub const SILENCE: std::time::Duration = std::time::Duration::from_secs(3);

/// Default ids per delta batch (the paper's b, sec. 3.5): HC sends a delta when this many
/// changes are pending, so OR and RVG can start on them while HC goes on.
pub const DEFAULT_BATCH_IDS: usize = 1024;
