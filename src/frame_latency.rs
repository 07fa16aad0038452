//! Stereo frame → setpoint latency for the flight report: how long after a frame was captured
//! the commander published the first setpoint that used the avoider's command made from it
//! (the thesis budgets ~50 ms: ~40 ms depth image, ~10 ms fuzzy decision, §3.3.2).
//!
//! Measured on the host's monotonic clock, from the report actor's receipt of the frame to its
//! receipt of that setpoint. The graph clock would not do: in lockstep runs simulated time
//! waits while the stereo matcher works, so on the graph clock the whole chain takes no time
//! at all; the wall clock shows what the processing costs on this machine.

use std::collections::VecDeque;
use std::time::Instant;

/// Frames remembered for matching commands to them: a few seconds at 15 Hz.
const FRAME_WINDOW: usize = 64;

/// The latency samples of one run and what is needed to take the next.
#[derive(Debug, Default)]
pub struct FrameLatency {
    /// `(sequence, received)` of recent frames, oldest first.
    frames: VecDeque<(u64, Instant)>,
    /// Receipt of the frame behind the newest command not yet followed by a setpoint.
    pending: Option<Instant>,
    /// Sequence of the last frame whose command has been counted (the avoider's staleness
    /// timer repeats a frame's sequence; only the first command made from a frame counts).
    counted: Option<u64>,
    samples_ms: Vec<f64>,
}

impl FrameLatency {
    /// A stereo frame arrived.
    pub fn on_frame(&mut self, sequence: u64, now: Instant) {
        if self.frames.len() == FRAME_WINDOW {
            self.frames.pop_front();
        }
        self.frames.push_back((sequence, now));
    }

    /// An avoidance command made from the frame `frame_sequence` arrived.
    pub fn on_command(&mut self, frame_sequence: Option<u64>) {
        let Some(sequence) = frame_sequence.filter(|s| self.counted != Some(*s)) else { return };
        if let Some(&(_, received)) = self.frames.iter().find(|(s, _)| *s == sequence) {
            self.pending = Some(received);
            self.counted = Some(sequence);
        }
    }

    /// A setpoint arrived: it carries the newest command, if one is pending.
    pub fn on_setpoint(&mut self, now: Instant) {
        if let Some(received) = self.pending.take() {
            self.samples_ms.push(now.duration_since(received).as_secs_f64() * 1e3);
        }
    }

    /// `(p50, p95)` in milliseconds, or `None` without samples.
    pub fn percentiles_ms(&self) -> Option<(f64, f64)> {
        kestrel_proto::percentiles::p50_p95(&self.samples_ms)
    }

    /// Number of samples.
    pub fn samples(&self) -> usize {
        self.samples_ms.len()
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn each_frame_counts_once_from_its_receipt_to_the_next_setpoint() {
        let t0 = Instant::now();
        let ms = |m: u64| t0 + Duration::from_millis(m);
        let mut l = FrameLatency::default();
        assert_eq!(l.percentiles_ms(), None);
        for k in 0..20u64 {
            l.on_frame(k, ms(100 * k));
            l.on_setpoint(ms(100 * k + 5));
            l.on_command(Some(k));
            // A repeat of the same frame's sequence (staleness timer) does not count again.
            l.on_command(Some(k));
            l.on_setpoint(ms(100 * k + 10 + k));
            l.on_setpoint(ms(100 * k + 50));
        }
        // A command for a frame never seen is not counted.
        l.on_command(Some(999));
        l.on_setpoint(ms(10_000));
        assert_eq!(l.samples(), 20);
        let (p50, p95) = l.percentiles_ms().expect("samples");
        assert!((p50 - 20.0).abs() < 1e-6 && (p95 - 28.0).abs() < 1e-6, "{p50} {p95}");
    }
}
