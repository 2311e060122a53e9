//! Clocks across hosts (one-way latency per link). Every process stamps with its
//! wall clock in microseconds; the display estimates each node's offset NTP-style: ping-pong
//! timestamps t0 (display sends), t1 (node receives), t2 (node replies), t3 (display
//! receives); the sample of least round trip t3 - t0 - (t2 - t1) gives the offset
//! ((t1 - t0) + (t2 - t3)) / 2 with an error of at most half that round trip.

/// Microseconds since the Unix epoch on this host's clock, read once at the process's first
/// call and advanced by the monotonic clock after it: a wall-clock step during a run (NTP)
/// changes no interval. The offsets are estimated once, at start-up; a run is short enough
/// that the clocks' drift does not matter.
pub fn now_us() -> u64 {
    use std::time::{Instant, SystemTime, UNIX_EPOCH};
    static ANCHOR: std::sync::OnceLock<(Instant, u64)> = std::sync::OnceLock::new();
    let (at, wall) =
        ANCHOR.get_or_init(|| (Instant::now(), SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_micros() as u64)));
    wall + at.elapsed().as_micros() as u64
}

/// One ping-pong exchange, each time on its own host's clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub t0: u64,
    pub t1: u64,
    pub t2: u64,
    pub t3: u64,
}

/// A node's clock relative to the display's: node time = display time + `offset_us`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Offset {
    pub offset_us: f64,
    /// Round trip of the sample used: the offset is right to within half of it.
    pub rtt_us: f64,
}

impl Offset {
    /// A stamp of that node's clock on the display's clock.
    pub fn to_display(&self, node_us: u64) -> f64 {
        node_us as f64 - self.offset_us
    }
}

impl Sample {
    pub fn rtt_us(&self) -> f64 {
        (self.t3 as f64 - self.t0 as f64) - (self.t2 as f64 - self.t1 as f64)
    }

    pub fn offset_us(&self) -> f64 {
        ((self.t1 as f64 - self.t0 as f64) + (self.t2 as f64 - self.t3 as f64)) / 2.0
    }
}

/// The offset from the sample of least round trip; `None` without samples.
pub fn estimate(samples: &[Sample]) -> Option<Offset> {
    let best = samples.iter().min_by(|a, b| a.rtt_us().total_cmp(&b.rtt_us()))?;
    Some(Offset { offset_us: best.offset_us(), rtt_us: best.rtt_us().max(0.0) })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node clock 5 s ahead, links of 300 µs one way plus queueing: the least round trip wins.
    #[test]
    fn offset_of_a_clock_ahead_with_asymmetric_queueing() {
        let ahead = 5_000_000;
        let ex = |t0: u64, up: u64, hold: u64, down: u64| Sample {
            t0,
            t1: t0 + up + ahead,
            t2: t0 + up + hold + ahead,
            t3: t0 + up + hold + down,
        };
        let samples = [ex(1_000, 900, 50, 300), ex(9_000, 300, 40, 300), ex(20_000, 300, 10, 2_000)];
        let o = estimate(&samples).unwrap();
        assert_eq!(o.rtt_us, 600.0);
        assert_eq!(o.offset_us, ahead as f64);
        assert_eq!(estimate(&[]), None);
        // A message the node stamped on sending, 300 µs before the display got it.
        let (display_at, node_sent) = (50_000_300u64, 50_000_000 + ahead);
        assert_eq!(display_at as f64 - o.to_display(node_sent), 300.0);
    }
}
