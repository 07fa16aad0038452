//! How long a bridged message took from the sending bridge to the receiving one (one hop), on
//! the wall clock both read: what splitting the graph across processes or machines costs.

/// Latency samples kept per topic: the newest ones, a few minutes at a grid's 15 Hz.
const WINDOW: usize = 4096;

/// One topic's hop latencies.
#[derive(Debug, Default)]
pub struct HopLatency {
    samples_ms: Vec<f64>,
    /// Where the next sample goes once the window is full.
    next: usize,
    received: u64,
}

impl HopLatency {
    /// A message sent at `sent_unix_us` arrived at `arrived_unix_us`. A negative difference
    /// (wall clocks of two machines that disagree) is kept as it is, so it shows.
    pub fn record(&mut self, sent_unix_us: i64, arrived_unix_us: i64) {
        let ms = arrived_unix_us.saturating_sub(sent_unix_us) as f64 / 1e3;
        self.received += 1;
        if self.samples_ms.len() < WINDOW {
            self.samples_ms.push(ms);
        } else {
            self.samples_ms[self.next] = ms;
            self.next = (self.next + 1) % WINDOW;
        }
    }

    /// Messages recorded so far.
    pub fn received(&self) -> u64 {
        self.received
    }

    /// `(p50, p95)` in milliseconds over the window, or `None` without samples.
    pub fn percentiles_ms(&self) -> Option<(f64, f64)> {
        kestrel_proto::percentiles::p50_p95(&self.samples_ms)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_cover_the_newest_window() {
        let mut h = HopLatency::default();
        assert_eq!(h.percentiles_ms(), None);
        for k in 0..100 {
            h.record(1_000_000, 1_000_000 + 1_000 * k);
        }
        assert_eq!(h.percentiles_ms(), Some((50.0, 94.0)));
        // A full window of 1 ms samples pushes the old ones out.
        for _ in 0..WINDOW {
            h.record(0, 1_000);
        }
        assert_eq!(h.percentiles_ms(), Some((1.0, 1.0)));
        assert_eq!(h.received(), 100 + WINDOW as u64);
    }
}
