//! Which IMU the filter predicts from, when the vehicle has more than one.
//!
//! Boards carry two or three IMUs (the Navio2 an MPU-9250 and an LSM9DS1) so that one stream
//! stopping is a failover, not a crash: with no IMU the filter cannot predict and the controller
//! flies blind. As PX4's `sensors` module does, one IMU is *in use* and the others are watched;
//! when the one in use has delivered nothing for [`IMU_TIMEOUT_S`] while another still delivers,
//! the filter switches to that one and stays on it (no switching back and forth: the biases the
//! filter learnt belong to one IMU, so every switch costs a bias re-convergence).

use kestrel_proto::Time;

/// Silence of the IMU in use after which another IMU's samples take over (s): PX4's
/// `DataValidator` timeout of 20 ms (`_timeout_interval`), 8 samples at 400 Hz.
pub const IMU_TIMEOUT_S: f64 = 0.02;
/// IMUs one estimator watches.
pub const MAX_IMUS: usize = 2;

/// What to do with one IMU sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuVerdict {
    /// From the IMU in use: predict with it.
    Use,
    /// From the IMU in use from now on, the previous one having fallen silent: reset what the
    /// filter learnt of the old IMU (its biases), then predict with it.
    SwitchedTo(usize),
    /// From a watched IMU: only its freshness counts.
    Watch,
}

/// The IMU in use and the newest sample time of each.
#[derive(Clone, Debug)]
pub struct ImuSelection {
    in_use: usize,
    newest: [Option<Time>; MAX_IMUS],
    /// The first sample of any IMU: an IMU in use that never delivered is silent since then.
    first: Option<Time>,
    switches: u32,
}

impl Default for ImuSelection {
    fn default() -> Self {
        ImuSelection { in_use: 0, newest: [None; MAX_IMUS], first: None, switches: 0 }
    }
}

impl ImuSelection {
    /// Takes the measurement time of a sample of IMU `instance` (0-based, below [`MAX_IMUS`];
    /// others are watched and never used).
    pub fn on_sample(&mut self, instance: usize, time: Time) -> ImuVerdict {
        let first = *self.first.get_or_insert(time);
        if let Some(newest) = self.newest.get_mut(instance) {
            *newest = Some(newest.map_or(time, |t| t.max(time)));
        } else {
            return ImuVerdict::Watch;
        }
        if instance == self.in_use {
            return ImuVerdict::Use;
        }
        let silent_since = self.newest[self.in_use].unwrap_or(first);
        if time.saturating_since(silent_since).as_secs_f64() > IMU_TIMEOUT_S {
            self.in_use = instance;
            self.switches += 1;
            return ImuVerdict::SwitchedTo(instance);
        }
        ImuVerdict::Watch
    }

    /// The IMU in use (0-based).
    pub fn in_use(&self) -> usize {
        self.in_use
    }

    /// Times the filter moved to another IMU.
    pub fn switches(&self) -> u32 {
        self.switches
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn t(ms: f64) -> Time {
        Time::from_secs_f64(ms / 1000.0)
    }

    #[test]
    fn the_first_imu_is_used_while_it_delivers_and_the_second_takes_over_after_20_ms() {
        let mut s = ImuSelection::default();
        let mut verdicts = Vec::new();
        for k in 0..40 {
            let ms = f64::from(k) * 2.5;
            // IMU 0 stops after 50 ms.
            if ms <= 50.0 {
                verdicts.push((ms, 0, s.on_sample(0, t(ms))));
            }
            verdicts.push((ms, 1, s.on_sample(1, t(ms))));
        }
        let switch = verdicts.iter().find(|v| matches!(v.2, ImuVerdict::SwitchedTo(_))).unwrap();
        // The first sample of IMU 1 more than 20 ms after IMU 0's last (50 ms).
        assert_eq!((switch.0, switch.1, switch.2), (72.5, 1, ImuVerdict::SwitchedTo(1)));
        assert!(
            verdicts
                .iter()
                .filter(|v| v.0 < 72.5)
                .all(|v| v.2 == if v.1 == 0 { ImuVerdict::Use } else { ImuVerdict::Watch })
        );
        assert!(verdicts.iter().filter(|v| v.0 > 72.5).all(|v| v.2 == ImuVerdict::Use));
        assert_eq!((s.in_use(), s.switches()), (1, 1));
    }

    #[test]
    fn there_is_no_switching_back_when_the_first_returns() {
        let mut s = ImuSelection::default();
        s.on_sample(0, t(0.0));
        assert_eq!(s.on_sample(1, t(30.0)), ImuVerdict::SwitchedTo(1));
        assert_eq!(s.on_sample(0, t(32.5)), ImuVerdict::Watch);
        assert_eq!(s.on_sample(1, t(32.5)), ImuVerdict::Use);
        assert_eq!(s.switches(), 1);
    }

    #[test]
    fn an_imu_in_use_that_never_delivered_is_silent_from_the_first_sample_of_any() {
        let mut s = ImuSelection::default();
        assert_eq!(s.on_sample(1, t(0.0)), ImuVerdict::Watch);
        assert_eq!(s.on_sample(1, t(20.0)), ImuVerdict::Watch);
        assert_eq!(s.on_sample(1, t(22.5)), ImuVerdict::SwitchedTo(1));
    }

    #[test]
    fn an_instance_beyond_the_watched_ones_is_never_used() {
        let mut s = ImuSelection::default();
        assert_eq!(s.on_sample(0, t(0.0)), ImuVerdict::Use);
        assert_eq!(s.on_sample(MAX_IMUS, t(500.0)), ImuVerdict::Watch);
        assert_eq!(s.in_use(), 0);
    }

    proptest! {
        /// Two IMUs that both deliver every 2.5 ms (in any interleaving, with jitter under the
        /// timeout) never cause a switch; exactly one sample per instant is used.
        #[test]
        fn two_healthy_imus_never_switch(order in proptest::collection::vec(any::<bool>(), 1..400),
                                         jitter in proptest::collection::vec(0.0f64..10.0, 400)) {
            let mut s = ImuSelection::default();
            let mut used = 0;
            for (k, first_is_zero) in order.iter().enumerate() {
                let ms = k as f64 * 2.5;
                let pair = if *first_is_zero { [0, 1] } else { [1, 0] };
                for i in pair {
                    let at = if i == 1 { ms + jitter[k] } else { ms };
                    if s.on_sample(i, t(at)) == ImuVerdict::Use {
                        used += 1;
                    }
                }
            }
            prop_assert_eq!(s.switches(), 0);
            prop_assert_eq!(used, order.len());
        }
    }
}
