//! The sensor calibration a driver's reader thread applies, changed by the actor from the ground
//! station's parameters without ever making the reader wait.
//!
//! The reader runs at the chip's output rate (1 kHz for the MPU-9250) and must not block on the
//! actor, which takes the lock only to store a new value. The reader looks at a generation
//! counter each sample and copies the new value with `try_lock` when it changed; if the actor
//! holds the lock at that instant, the reader keeps the old correction for one more sample.
//! The same holds for whether a calibration wants raw samples (`imu_raw`, `mag_raw`).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use kestrel_proto::calibration::SensorCalibration;

/// What the actor sets and the reader follows.
#[derive(Debug, Default)]
pub struct LiveCalibration {
    current: Mutex<SensorCalibration>,
    /// Bumped after each new value is stored.
    generation: AtomicU64,
    /// A calibration is running and wants the uncorrected samples.
    raw_wanted: AtomicBool,
}

impl LiveCalibration {
    /// Stores `calibration` for the reader to pick up at its next sample.
    pub fn set(&self, calibration: SensorCalibration) {
        *self.current.lock().unwrap_or_else(|e| e.into_inner()) = calibration;
        self.generation.fetch_add(1, Ordering::Release);
    }

    /// Whether the reader publishes the uncorrected samples too.
    pub fn set_raw_wanted(&self, wanted: bool) {
        self.raw_wanted.store(wanted, Ordering::Relaxed);
    }

    /// A reader's view, starting from what is stored now.
    pub fn reader(self: &Arc<Self>) -> CalibrationReader {
        let mut reader = CalibrationReader {
            shared: Arc::clone(self),
            local: SensorCalibration::default(),
            seen: u64::MAX,
        };
        reader.current();
        reader
    }
}

/// The reader thread's copy of the calibration.
#[derive(Debug)]
pub struct CalibrationReader {
    shared: Arc<LiveCalibration>,
    local: SensorCalibration,
    /// The generation `local` was copied at.
    seen: u64,
}

impl CalibrationReader {
    /// The calibration to apply now: the newest stored, unless the actor is storing one at this
    /// very moment (then the previous one, for this sample). Never blocks, never allocates.
    pub fn current(&mut self) -> &SensorCalibration {
        let generation = self.shared.generation.load(Ordering::Acquire);
        if generation != self.seen
            && let Ok(stored) = self.shared.current.try_lock()
        {
            self.local.clone_from(&stored);
            self.seen = generation;
        }
        &self.local
    }

    /// Whether a running calibration wants the uncorrected samples.
    pub fn raw_wanted(&self) -> bool {
        self.shared.raw_wanted.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::calibration::MagCalibration;

    use super::*;

    fn with_hard_iron(x: f64) -> SensorCalibration {
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        SensorCalibration {
            mag: MagCalibration::new([x, 0.0, 0.0], identity).expect("valid"),
            ..SensorCalibration::default()
        }
    }

    #[test]
    fn the_reader_follows_each_new_value() {
        let live = Arc::new(LiveCalibration::default());
        let mut reader = live.reader();
        assert_eq!(reader.current(), &SensorCalibration::default());
        live.set(with_hard_iron(0.15));
        assert_eq!(reader.current(), &with_hard_iron(0.15));
        live.set(with_hard_iron(-0.1));
        assert_eq!(reader.current(), &with_hard_iron(-0.1));
        assert!(!reader.raw_wanted());
        live.set_raw_wanted(true);
        assert!(reader.raw_wanted());
    }

    #[test]
    fn a_held_lock_leaves_the_reader_on_the_old_value_without_waiting() {
        let live = Arc::new(LiveCalibration::default());
        let mut reader = live.reader();
        let guard = live.current.lock().expect("lock");
        live.generation.fetch_add(1, Ordering::Release);
        assert_eq!(reader.current(), &SensorCalibration::default(), "kept, not waited for");
        drop(guard);
        live.set(with_hard_iron(0.2));
        assert_eq!(reader.current(), &with_hard_iron(0.2), "picked up once free");
    }
}
